//! The start the `sable bench` subcommands share: their scene built for the threads asked and
//! the pool it runs in, as a job would.

/// The benchmark scene `make` builds for the thread count asked (all cores by default), the
/// threads it gets after the job's budget, and the pool it runs in — as in a job: the whole run
/// inside one pool, not a hand-off to the method's pool per step.
pub(super) fn prepare(
    threads: Option<usize>,
    make: impl FnOnce(usize) -> serde_json::Value,
) -> anyhow::Result<(sable_engine::methods::Plan, usize, rayon::ThreadPool)> {
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let mut scene =
        sable_engine::methods::plan_scene(&make(threads).to_string()).map_err(|v| anyhow::anyhow!("benchmark scene invalid: {v:?}"))?;
    let threads = sable_worker::execute::apply_thread_budget(&mut scene, threads);
    let pool = sable_worker::execute::job_pool(threads).map_err(anyhow::Error::msg)?;
    Ok((scene, threads, pool))
}

//! `--trace FILE` of `sable run` and `sable bench mpm|fem`: a soft-grain method's Newton
//! iterations, one JSON object per line ([`sable_engine::methods::soft::trace`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::Context;
use sable_engine::methods::registry;
use sable_engine::methods::soft::trace::NewtonSink;

/// The file the records go to, written from the method's thread.
pub(super) struct TraceFile {
    path: PathBuf,
    out: Arc<Mutex<std::io::BufWriter<std::fs::File>>>,
    /// The first write error, reported by [`TraceFile::finish`].
    error: Arc<Mutex<Option<std::io::Error>>>,
}

impl TraceFile {
    /// Creates `path` for a run of `method`; an error names the flag when the method has no
    /// Newton iterations (nothing is created then).
    pub(super) fn create(path: &Path, method: &str) -> anyhow::Result<Self> {
        if !registry::entry(method).is_some_and(|e| e.newton) {
            anyhow::bail!("--trace: method {method} has no Newton iterations to trace ({} have)", registry::traced().join(" and "));
        }
        let file = std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        Ok(Self { path: path.to_path_buf(), out: Arc::new(Mutex::new(std::io::BufWriter::new(file))), error: Arc::new(Mutex::new(None)) })
    }

    /// The sink to give the method.
    pub(super) fn sink(&self) -> NewtonSink {
        let (out, error) = (self.out.clone(), self.error.clone());
        Box::new(move |record| {
            let Ok(mut error) = error.lock() else { return };
            if error.is_some() {
                return;
            }
            let Ok(mut out) = out.lock() else { return };
            let written = serde_json::to_writer(&mut *out, record).map_err(std::io::Error::from).and_then(|()| writeln!(out));
            if let Err(e) = written {
                *error = Some(e);
            }
        })
    }

    /// Flushes the file; the first error of any write, if one failed.
    pub(super) fn finish(self) -> anyhow::Result<()> {
        let cannot = || format!("cannot write the trace {}", self.path.display());
        if let Some(e) = self.error.lock().ok().and_then(|mut e| e.take()) {
            return Err(anyhow::Error::from(e).context(cannot()));
        }
        let mut out = self.out.lock().map_err(|_| anyhow::anyhow!("{}: a writer panicked", cannot()))?;
        out.flush().with_context(cannot)
    }
}

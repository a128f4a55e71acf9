//! Submits a scene to a running server and prints its progress, then its last sample.
//!
//! ```sh
//! sable serve &            # in another terminal
//! cargo run -p sable-client --example submit_and_watch -- scenes/quickstart.json
//! ```

use sable_client::{Client, SubmitOptions, DEFAULT_SERVER};
use sable_proto::v1::job_event::Kind;
use tokio_stream::StreamExt;

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| "scenes/quickstart.json".into());
    let server = std::env::var("SABLE_SERVER").unwrap_or_else(|_| DEFAULT_SERVER.into());
    let scene = std::fs::read_to_string(&path)?;
    let mut client = Client::connect(&server).await?;
    let job = client.submit(&scene, SubmitOptions::default()).await?;
    println!("job {} queued", job.id);
    let mut events = client.watch(job.id, 0);
    while let Some(ev) = events.next().await {
        match ev?.kind {
            Some(Kind::State(s)) => println!("state: {:?} {}", s.state(), s.error_message),
            Some(Kind::Sample(s)) => {
                if let Some(x) = s.sample {
                    let ratio = x.mu.map_or_else(|| format!("zeta {:.3}", x.zeta), |mu| format!("mu {mu:.3}"));
                    println!("{:5.1}%  step {:>8}  phi {:.4}  Z {:.3}  {ratio}", 100.0 * s.fraction, x.step, x.phi, x.z);
                }
            }
            _ => {}
        }
    }
    let samples = client.samples(job.id, 0, None, None).await?;
    if let Some(last) = samples.last() {
        println!("{}", serde_json::to_string_pretty(last)?);
    }
    Ok(())
}

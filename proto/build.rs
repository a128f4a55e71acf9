//! Compiles proto/sable/v1/*.proto with protox (a pure-Rust protobuf compiler: no protoc to
//! install) and generates the tonic client and server code, plus the file descriptor set that
//! gRPC server reflection serves.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let files = ["sable/v1/simulations.proto"];
    for f in files {
        println!("cargo:rerun-if-changed={f}");
    }
    let fds = protox::compile(files, ["."])?;
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(out.join("sable_descriptor.bin"), prost::Message::encode_to_vec(&fds))?;
    tonic_prost_build::configure().compile_fds(fds)?;
    Ok(())
}

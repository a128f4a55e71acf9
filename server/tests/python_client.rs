//! The Python client (client/python) against this build of `sable serve`: installs the package
//! with pip into a virtual environment under the target directory and runs its pytest suite,
//! which starts the server from `CARGO_BIN_EXE_sable`. Needs `python3` (3.10 or later, with
//! venv and pip) and, on the first run, the PyPI registry: the environment is made once, with
//! setuptools and the package's dependencies; later runs find them installed and reinstall
//! only the package, built without an isolated environment, so they need no registry.

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(what: &str, cmd: &mut Command) {
    let out = cmd.output().unwrap_or_else(|e| panic!("{what}: cannot start {cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n--- stdout\n{}\n--- stderr\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root.join("target"))
}

#[test]
fn the_python_client_passes_its_tests_against_this_server() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the workspace root").to_path_buf();
    let venv = target_dir(&root).join("python-client-venv");
    let python = venv.join("bin").join("python");
    if !python.is_file() {
        let system = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
        run("creating the virtual environment", Command::new(system).args(["-m", "venv"]).arg(&venv));
    }
    // What builds the package (already there after the first run: pip then asks no registry).
    run(
        "pip install setuptools",
        Command::new(&python).args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "setuptools>=68", "wheel"]),
    );
    run(
        "pip install ./client/python[test]",
        Command::new(&python)
            .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-build-isolation", "./client/python[test]"])
            .current_dir(&root),
    );
    // The TLS service's self-signed certificate (Python's standard library cannot make one).
    let tls = tempfile::tempdir().expect("dir");
    let names = vec!["localhost".to_string(), "127.0.0.1".to_string()];
    let rcgen::CertifiedKey { cert, key_pair } = rcgen::generate_simple_self_signed(names).expect("certificate");
    let (cert_file, key_file) = (tls.path().join("cert.pem"), tls.path().join("key.pem"));
    std::fs::write(&cert_file, cert.pem()).expect("write");
    std::fs::write(&key_file, key_pair.serialize_pem()).expect("write");
    run(
        "pytest client/python/tests",
        Command::new(&python)
            .args(["-m", "pytest", "client/python/tests", "-q", "-p", "no:cacheprovider"])
            .env("SABLE_BIN", env!("CARGO_BIN_EXE_sable"))
            .env("SABLE_TEST_TLS_CERT", &cert_file)
            .env("SABLE_TEST_TLS_KEY", &key_file)
            .env_remove("SABLE_CA_CERT")
            .current_dir(&root),
    );
}

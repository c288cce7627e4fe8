//! The Python package (`python/`), installed as its users install it:
//! `pip install ./python` from the repository root (maturin builds the
//! binding into the build cache), into a scratch virtualenv with pyarrow,
//! ArviZ, pytest and mypy. Then pytest runs its checks (python/tests:
//! decoded tables equal to this build's `acq decode -o FILE.parquet`, a
//! study run from Python read back, ArviZ's R-hat and ESS on `to_arviz()`
//! equal to summary.json's), and mypy checks the typed example against the
//! package's annotations and refuses each call marked as a misuse.

mod common;

use std::process::Command;

use common::root;

#[test]
fn pip_installs_the_package_and_its_checks_pass() {
    let python = common::scratch_python("python-package");
    let installed = Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--force-reinstall",
            "--no-deps",
            "./python",
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        installed.status.success(),
        "pip install ./python failed:\n{}",
        String::from_utf8_lossy(&installed.stderr)
    );

    let pytest = Command::new(&python)
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .current_dir(root())
        .env("ACQ_REPO", root())
        .env("ACQ_BIN", env!("CARGO_BIN_EXE_acq"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&pytest.stdout);
    assert!(
        pytest.status.success(),
        "pytest python/tests:\n{said}\n{}",
        String::from_utf8_lossy(&pytest.stderr)
    );
    // Every check ran (none skipped for a missing tool).
    assert!(
        said.contains("22 passed") && !said.contains("skipped"),
        "{said}"
    );

    let cache = tempfile::tempdir().unwrap();
    let mypy = |file: &str| {
        Command::new(&python)
            .args(["-m", "mypy", "--config-file", "mypy.ini", "--cache-dir"])
            .arg(cache.path())
            .arg(file)
            .current_dir(root().join("python"))
            .output()
            .unwrap()
    };
    let typed = mypy("tests/typed_example.py");
    assert!(
        typed.status.success(),
        "mypy on the typed example:\n{}",
        String::from_utf8_lossy(&typed.stdout)
    );
    let misuse = mypy("tests/typed_misuse.py");
    let found = String::from_utf8_lossy(&misuse.stdout);
    let source = std::fs::read_to_string(root().join("python/tests/typed_misuse.py")).unwrap();
    for (k, line) in source.lines().enumerate() {
        if line.contains("# misuse") {
            let at = format!("typed_misuse.py:{}: error:", k + 1);
            assert!(
                found.contains(&at),
                "mypy let line {} pass: {line}\n{found}",
                k + 1
            );
        }
    }
}

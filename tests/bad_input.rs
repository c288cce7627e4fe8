//! Careless input, class by class, through the real binary: each test is one
//! class of defect (an output over an input, a half-made output, a path or
//! name from a file leaving its directory, a number outside what the
//! physics or the machine allows, a DBC that cannot be decoded, a study
//! that cannot work, a log cut short, a failed command's output, a message
//! that names a consequence instead of the mistake, a result that depends
//! on machine load), tried with several inputs, asserting the exit code
//! and what the message says. The fixes live in one place each
//! (`acq_io::output`, `acq_io::input::parse_duration`, the DBC compiler,
//! the twins' input checks, the calibration's check before its first run,
//! each log reader's end, `acq_analysis::decode`, `cli::parse`, the spec's
//! checks, the search's synchronous batches).

mod common;

use std::path::{Path, PathBuf};

use common::{acq, calibrate_external, path_arg, root, stderr};

/// Runs acq, expects `code`, and returns stderr.
fn refused(args: &[&str], code: i32) -> String {
    let output = acq(args);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(code), "{args:?}: {message}");
    assert!(!message.contains("panicked"), "{args:?}: {message}");
    message
}

/// Runs `acq calibrate external` on `spec`, expects exit 2, returns stderr.
fn refused_external(spec: &Path, out: &Path) -> String {
    let output = calibrate_external(spec, out, &[]);
    let message = stderr(&output);
    assert_eq!(
        output.status.code(),
        Some(2),
        "{}: {message}",
        spec.display()
    );
    assert!(
        !message.contains("panicked"),
        "{}: {message}",
        spec.display()
    );
    message
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn copy_session(name: &str, to: &Path) -> PathBuf {
    let target = to.join(name);
    let source = root().join("fixtures/sessions").join(name);
    std::fs::create_dir_all(target.join("rig")).unwrap();
    for entry in walk(&source) {
        let relative = entry.strip_prefix(&source).unwrap();
        let destination = target.join(relative);
        std::fs::create_dir_all(destination.parent().unwrap()).unwrap();
        std::fs::copy(&entry, destination).unwrap();
    }
    target
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else {
            files.push(path);
        }
    }
    files
}

/// Every file under `dir` with its SHA-256, by path.
fn hashes(dir: &Path) -> std::collections::BTreeMap<PathBuf, String> {
    walk(dir)
        .into_iter()
        .map(|path| {
            let (sha, _) = acq_io::session::sha256_file(&path).unwrap();
            (path, sha)
        })
        .collect()
}

/// The sweep's rule for the commands of rounds three and four (`budget`,
/// `check-rig` with a sensor file, `zero`, `shunt`, `mesh-study`,
/// `import`, and `extract` of what they leave): every input is hashed
/// before and after each careless or good call, and none changes, moves or
/// gains a neighbour, but for the one record a command is made to write
/// (`zero.toml` in the session it zeroes).
#[test]
fn the_new_commands_leave_every_input_as_it_was() {
    let temp = tempfile::tempdir().unwrap();
    let inputs = temp.path().join("inputs");
    std::fs::create_dir(&inputs).unwrap();
    let session = copy_session("excavator_case2", &inputs);
    let rig = session.join("rig/excavator.toml");
    let chain = inputs.join("measurement-chain");
    std::fs::create_dir(&chain).unwrap();
    for name in ["rig.toml", "sensors.toml"] {
        std::fs::copy(
            root().join("examples/measurement-chain").join(name),
            chain.join(name),
        )
        .unwrap();
    }
    let spec = inputs.join("gtn-mesh/spec.toml");
    std::fs::create_dir(spec.parent().unwrap()).unwrap();
    std::fs::copy(root().join("examples/gtn-mesh/spec.toml"), &spec).unwrap();
    let log = inputs.join("case2.log");
    std::fs::copy(session.join("raw.log"), &log).unwrap();
    let outputs = temp.path().join("outputs");
    let (chain_rig, session) = (chain.join("rig.toml"), session.clone());
    let [chain_rig, s, rig, spec, log, spec_dir, outputs_dir] = [
        &chain_rig,
        &session,
        &rig,
        &spec,
        &log,
        spec.parent().unwrap(),
        &outputs,
    ]
    .map(|path| path_arg(path).to_string());
    // (The temporary paths hold no spaces: each call is one line.)
    let calls: Vec<Vec<String>> = [
        format!("budget {chain_rig} --sensor boom_head_pressure --at 1e308"),
        format!("budget {chain_rig} --sensor boom_head_pressure --at 120"),
        format!("budget {rig} --cylinder boom --head 1e300 --rod 0"),
        format!("check-rig {chain_rig}"),
        format!("zero {s} --before 30s"),
        format!("zero {s} --before 5s"),
        format!("zero {s} --before 0.5s --after 5s"),
        format!("shunt {s} --rig {rig} --sensor sg01 --from 1s --to 6s"),
        format!("mesh-study --spec {spec} --out {spec_dir}"),
        format!("import {log} --rig {rig} --out {s}"),
        format!("import {log} {log} --rig {rig} --out {s}"),
        format!("import {log} --rig {rig} --out {outputs_dir}/imported"),
        format!("zero {s} --before 0.5s"),
        format!("extract {s} -o {outputs_dir}/measured.csv"),
    ]
    .iter()
    .map(|call| call.split_whitespace().map(str::to_string).collect())
    .collect();
    std::fs::create_dir(&outputs).unwrap();
    let mut before = hashes(&inputs);
    for call in &calls {
        let args: Vec<&str> = call.iter().map(String::as_str).collect();
        let output = acq(&args);
        assert!(!stderr(&output).contains("panicked"), "{args:?}");
        let mut after = hashes(&inputs);
        // The one record a command is made to write.
        if args[0] == "zero" && output.status.success() {
            assert!(
                after.remove(&session.join("zero.toml")).is_some(),
                "{args:?}"
            );
            before.remove(&session.join("zero.toml"));
        }
        assert_eq!(after, before, "{args:?}: an input changed");
        before = hashes(&inputs);
    }
    assert!(
        session.join("zero.toml").exists(),
        "the good zero was taken"
    );
    assert!(outputs.join("imported/raw.log").exists());
    assert!(outputs.join("measured.csv").exists());
}

// ---- an output never replaces an input ----------------------------------------------------
// ---- an output never replaces an input ----------------------------------------------------

#[test]
fn no_output_replaces_an_input_of_the_same_command() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("same.log");
    std::fs::copy(root().join("fixtures/logs/excavator_case1.log"), &log).unwrap();
    let original = std::fs::read(&log).unwrap();
    let linked = dir.path().join("hard-link.log");
    std::fs::hard_link(&log, &linked).unwrap();
    let session = copy_session("excavator_case1", dir.path());
    let rig = root().join("fixtures/rigs/excavator.toml");
    let raw = session.join("raw.log");
    let raw_before = std::fs::read(&raw).unwrap();
    let scenario = dir.path().join("scenario.toml");
    std::fs::copy(
        root().join("fixtures/scenarios/excavator_case1.toml"),
        &scenario,
    )
    .unwrap();
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "decode",
            path_arg(&log),
            "--rig",
            path_arg(&rig),
            "-o",
            path_arg(&log),
        ],
        // The same file under another name.
        vec![
            "decode",
            path_arg(&log),
            "--rig",
            path_arg(&rig),
            "-o",
            path_arg(&linked),
        ],
        vec!["align", path_arg(&session), "-o", path_arg(&raw)],
        vec!["extract", path_arg(&session), "-o", path_arg(&raw)],
        vec![
            "simulate",
            "--rig",
            path_arg(&rig),
            "--scenario",
            path_arg(&scenario),
            "-o",
            path_arg(&scenario),
        ],
    ];
    for args in &cases {
        let message = refused(args, 2);
        assert!(
            message.contains("an input of this command"),
            "{args:?}: {message}"
        );
    }
    assert_eq!(std::fs::read(&log).unwrap(), original);
    assert_eq!(std::fs::read(&raw).unwrap(), raw_before);
    assert!(std::fs::read_to_string(&scenario)
        .unwrap()
        .contains("[timeline]"));
    // Nothing was left beside them either.
    assert!(!files_in(dir.path()).iter().any(|n| n.ends_with(".partial")));
    assert!(!files_in(&session).iter().any(|n| n.ends_with(".partial")));
}

/// What a command reads without naming it on its command line is an
/// input too: a log on standard input (redirected from the file the output
/// names), the DBC files and sensor file a rig names, a session's own
/// copies of its rig and DBC, and its zero record. Each is refused (exit
/// 2) and kept byte for byte.
#[test]
fn files_reached_through_stdin_a_rig_or_a_session_are_inputs_too() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("mine.log");
    std::fs::copy(root().join("fixtures/logs/excavator_case1.log"), &log).unwrap();
    let rig_dir = dir.path().join("rigs");
    std::fs::create_dir(&rig_dir).unwrap();
    let dbc = rig_dir.join("somat_excavator.dbc");
    std::fs::copy(root().join("fixtures/dbc/somat_excavator.dbc"), &dbc).unwrap();
    let rig = rig_dir.join("mine.toml");
    std::fs::write(
        &rig,
        std::fs::read_to_string(root().join("fixtures/rigs/excavator.toml"))
            .unwrap()
            .replace("../dbc/somat_excavator.dbc", "somat_excavator.dbc"),
    )
    .unwrap();
    let session = copy_session("excavator_case2", dir.path());
    let zeroed = acq(&["zero", path_arg(&session), "--before", "0.5s"]);
    assert!(zeroed.status.success(), "{}", stderr(&zeroed));
    let kept: Vec<PathBuf> = vec![
        log.clone(),
        dbc.clone(),
        session.join("rig/excavator.toml"),
        session.join("rig/somat_excavator.dbc"),
        session.join("zero.toml"),
    ];
    let before: Vec<Vec<u8>> = kept.iter().map(|p| std::fs::read(p).unwrap()).collect();

    let stdin = std::process::Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["decode", "-", "--rig", path_arg(&rig), "-o", path_arg(&log)])
        .stdin(std::fs::File::open(&log).unwrap())
        .output()
        .unwrap();
    assert_eq!(stdin.status.code(), Some(2), "{}", stderr(&stdin));
    assert!(
        stderr(&stdin).contains("an input of this command"),
        "{}",
        stderr(&stdin)
    );
    for args in [
        vec![
            "decode",
            path_arg(&log),
            "--rig",
            path_arg(&rig),
            "-o",
            path_arg(&dbc),
        ],
        vec!["extract", path_arg(&session), "-o", path_arg(&kept[2])],
        vec!["align", path_arg(&session), "-o", path_arg(&kept[3])],
        vec!["extract", path_arg(&session), "-o", path_arg(&kept[4])],
    ] {
        let message = refused(&args, 2);
        assert!(
            message.contains("an input of this command"),
            "{args:?}: {message}"
        );
    }
    for (path, bytes) in kept.iter().zip(&before) {
        assert_eq!(
            &std::fs::read(path).unwrap(),
            bytes,
            "{} changed",
            path.display()
        );
    }
}

/// A session's own files cannot lead a reader astray: session.toml's
/// rig copy may not point outside the session (the rig there is never
/// loaded), and a raw log that is a FIFO is refused at once rather than
/// read for ever (the command is given ten seconds).
#[test]
fn a_session_file_cannot_lead_outside_its_directory_nor_block_on_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let session = copy_session("excavator_case1", dir.path());
    let outside = dir.path().join("outside");
    std::fs::create_dir(&outside).unwrap();
    std::fs::copy(session.join("rig/excavator.toml"), outside.join("rig.toml")).unwrap();
    let toml_path = session.join("session.toml");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    std::fs::write(
        &toml_path,
        text.replace(
            "copy = \"rig/excavator.toml\"",
            "copy = \"../outside/rig.toml\"",
        ),
    )
    .unwrap();
    let message = refused(&["extract", path_arg(&session), "-o", "-"], 2);
    assert!(
        message.contains("[rig.file] copy") && message.contains("no '..'"),
        "{message}"
    );

    let fifo_session = copy_session("excavator_case2", dir.path());
    let raw = fifo_session.join("raw.log");
    std::fs::remove_file(&raw).unwrap();
    nix::unistd::mkfifo(&raw, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["view", path_arg(&fifo_session), "--view", "127.0.0.1:0"])
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("acq view waited on a FIFO raw.log for 10 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut said = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut said).unwrap();
    assert_eq!(status.code(), Some(2), "{said}");
    assert!(said.contains("not a regular file"), "{said}");

    // The same for what a user names: a spec, a rig, a measured curve.
    let fifo = dir.path().join("fifo.toml");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    for args in [
        vec![
            "calibrate",
            "external",
            "--spec",
            path_arg(&fifo),
            "--out",
            "/nonexistent/never",
        ],
        vec!["check-rig", path_arg(&fifo)],
        vec!["tensile-props", path_arg(&fifo)],
    ] {
        let message = refused(&args, 2);
        assert!(
            message.contains("not a regular file"),
            "{args:?}: {message}"
        );
    }
}

/// A preset's posterior is bounded as a spec's is: 100 to a million kept
/// draws per chain, refused before any model run.
#[test]
fn a_presets_posterior_draws_are_bounded_as_a_specs() {
    for draws in ["0", "99", "1000001", "10000000000"] {
        let message = refused(
            &[
                "calibrate",
                "gtn",
                "--test",
                "data/tensile/P91_20_2_DF_SS.csv",
                "--posterior",
                "--posterior-draws",
                draws,
                "--out",
                "/nonexistent/never",
            ],
            2,
        );
        assert!(
            message.contains("give 100 to 1000000"),
            "{draws}: {message}"
        );
    }
    let message = refused(
        &[
            "calibrate",
            "excavator",
            "--case",
            "data/excavator/case1.toml",
            "--posterior",
            "--posterior-draws",
            "5",
            "--out",
            "/nonexistent/never",
        ],
        2,
    );
    assert!(message.contains("give 100 to 1000000"), "{message}");
}

// ---- a refused command leaves nothing behind ----------------------------------------------

#[test]
fn a_refused_command_leaves_no_half_made_output() {
    let dir = tempfile::tempdir().unwrap();
    let session = root().join("fixtures/sessions/excavator_case1");
    let aligned = dir.path().join("aligned.csv");
    for options in [
        vec!["--rate", "0"],
        vec!["--from", "10", "--to", "2"],
        vec!["--clock-offset", "nosuchbus=5"],
        vec!["--max-gap", "-5s"],
    ] {
        let mut args = vec!["align", path_arg(&session), "-o", path_arg(&aligned)];
        args.extend(options.iter().copied());
        refused(&args, 2);
        assert_eq!(files_in(dir.path()), Vec::<String>::new(), "{options:?}");
    }
    // A demo on a directory without sessions makes no output directory.
    let out = dir.path().join("demo-out");
    let empty = dir.path().join("no-sessions");
    std::fs::create_dir(&empty).unwrap();
    let message = refused(
        &[
            "demo",
            "--sessions",
            path_arg(&empty),
            "--out",
            path_arg(&out),
        ],
        2,
    );
    assert!(message.contains("excavator_case1"), "{message}");
    assert!(!out.exists());
    // An output directory that is a file is said to be one.
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let message = refused(
        &[
            "calibrate",
            "excavator",
            "--case",
            "data/excavator/case1.toml",
            "--out",
            path_arg(&file),
        ],
        2,
    );
    assert!(message.contains("not a directory"), "{message}");
}

// ---- names and paths from files stay where they belong ------------------------------------

fn external_spec(dir: &Path, replace: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join("fixtures/external/spec.toml")).unwrap();
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    std::fs::copy(
        root().join("fixtures/external/solver.sh"),
        dir.join("solver.sh"),
    )
    .unwrap();
    let spec = dir.join(format!("spec{}.toml", text.len()));
    std::fs::write(&spec, text).unwrap();
    spec
}

#[test]
fn paths_and_names_from_files_cannot_leave_their_directory() {
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, "keep me").unwrap();
    let victim_text = format!("output_file = \"{}\"", victim.display());
    for output_file in [
        victim_text.as_str(),
        "output_file = \"../../evaluations.csv\"",
        "output_file = \"\"",
    ] {
        let spec = external_spec(dir.path(), &[("output_file = \"out.json\"", output_file)]);
        let out = dir.path().join("run");
        let message = refused_external(&spec, &out);
        assert!(message.contains("output_file"), "{message}");
        assert!(!out.exists(), "{output_file}: a run directory was made");
    }
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");

    // A case name with a path in it names a file here, not elsewhere.
    let case_text = std::fs::read_to_string(root().join("data/excavator/case1.toml"))
        .unwrap()
        .replace("name = \"case1\"", "name = \"../../elsewhere/x\"");
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    std::fs::write(work.join("case.toml"), case_text).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_acq"))
        .args([
            "sensitivity",
            "excavator",
            "--case",
            "case.toml",
            "--points",
            "3",
        ])
        .current_dir(&work)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let written = files_in(&work);
    assert!(
        written.contains(&"_.._elsewhere_x-sensitivity.csv".to_string()),
        "{written:?}"
    );
    assert!(!dir.path().join("elsewhere").exists());
}

// ---- numbers: finite, in range, with the limit in the message -----------------------------

#[test]
fn numbers_outside_what_physics_or_the_machine_allows_are_refused_with_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    // External spec numbers (a timeout past Instant's range panicked).
    for (from, to, said) in [
        ("timeout_s = 1.0", "timeout_s = 1e19", "10000000"),
        ("timeout_s = 1.0", "timeout_s = 1e300", "10000000"),
        ("timeout_s = 1.0", "timeout_s = -1", "10000000"),
        ("parallel = 2", "parallel = 100000", "256"),
        ("retries = 0", "retries = 1000000", "100"),
        ("max_evals = 20", "max_evals = 100000000", "100000"),
        (
            "start = \"lhs\"",
            "start = \"voodoo\"",
            "lhs, sobol, l12, factorial",
        ),
    ] {
        let spec = external_spec(dir.path(), &[(from, to)]);
        let out = dir.path().join("run");
        let message = refused_external(&spec, &out);
        assert!(message.contains(said), "{to}: {message}");
        assert!(!out.exists());
    }

    // Command-line counts: each has a bound, and says it.
    let case = "data/excavator/case1.toml";
    for (option, value, said) in [
        ("--generations", "4000000000", "1..=100000"),
        ("--parallel", "100000", "1..=256"),
    ] {
        let out = dir.path().join("counts");
        let message = refused(
            &[
                "calibrate",
                "excavator",
                "--case",
                case,
                "--out",
                path_arg(&out),
                option,
                value,
            ],
            2,
        );
        assert!(message.contains(said), "{option} {value}: {message}");
        assert!(!out.exists());
    }
    // A budget beyond the transducer's full scale has nothing behind it.
    let rig = "fixtures/rigs/excavator.toml";
    for args in [
        &["--cylinder", "boom", "--head", "1e300", "--rod", "5"][..],
        &["--cylinder", "boom", "--head", "100", "--rod", "-50"],
        &["--sensor", "boom_head_pressure", "--at", "601"],
    ] {
        let mut line = vec!["budget", rig];
        line.extend(args);
        let message = refused(&line, 2);
        assert!(
            message.contains("pressure's range, 0 to 600 bar (the rig file's)"),
            "{args:?}: {message}"
        );
    }

    // Scenario levels and durations.
    let scenario =
        std::fs::read_to_string(root().join("fixtures/scenarios/excavator_case1.toml")).unwrap();
    let rig = root().join("fixtures/rigs/excavator.toml");
    for (from, to, said) in [
        ("hold_s = ", "hold_s = 1e12 #", "at most 86400"),
        ("hold = ", "hold = nan #", "finite"),
        ("hold = ", "hold = 1e30 #", "no pressure a sensor reads"),
        ("hold = ", "hold = -1e6 #", "from -1.01325 to 10000 bar"),
    ] {
        let text = scenario.replacen(from, to, 1);
        assert_ne!(text, scenario);
        let path = dir.path().join("scenario.toml");
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join("sim.log");
        let message = refused(
            &[
                "simulate",
                "--rig",
                path_arg(&rig),
                "--scenario",
                path_arg(&path),
                "-o",
                path_arg(&out),
            ],
            2,
        );
        assert!(message.contains(said), "{to}: {message}");
        assert!(!out.exists());
    }

    // A level inside the physical range but outside what the device sends:
    // the crosshead's 16-bit signal of 1 um steps ends at 32.767 mm.
    let path = dir.path().join("crosshead.toml");
    std::fs::write(
        &path,
        "name = \"too far\"\n[sensor.crosshead]\nidle = 0.0\nhold = 100.0\n",
    )
    .unwrap();
    let message = refused(
        &[
            "simulate",
            "--rig",
            "fixtures/rigs/tensile.toml",
            "--scenario",
            path_arg(&path),
            "-o",
            path_arg(&dir.path().join("crosshead.log")),
        ],
        2,
    );
    assert!(
        message.contains("hold = 100.0 mm cannot be sent") && message.contains("32.767"),
        "{message}"
    );

    // A rig rate no bus can carry.
    let rig_text = std::fs::read_to_string(&rig).unwrap();
    let fast = rig_text.replacen("rate_hz = 100", "rate_hz = 1e300", 1);
    assert_ne!(fast, rig_text);
    let fast_rig = root()
        .join("fixtures/rigs")
        .join(format!(".fast-{}.toml", std::process::id()));
    std::fs::write(&fast_rig, fast).unwrap();
    let message = refused(&["check-rig", path_arg(&fast_rig)], 2);
    std::fs::remove_file(&fast_rig).unwrap();
    assert!(message.contains("100000"), "{message}");

    // Command-line numbers.
    for (args, said) in [
        (
            vec![
                "moo",
                "--problem",
                "zdt1",
                "--pop",
                "100000000",
                "-o",
                "x.csv",
            ],
            "100000",
        ),
        (
            vec![
                "twin",
                "excavator",
                "--case",
                "data/excavator/case1.toml",
                "--force=1e308",
            ],
            "10000 kN",
        ),
        (
            vec![
                "twin",
                "excavator",
                "--case",
                "data/excavator/case1.toml",
                "--force=-5",
            ],
            "10000 kN",
        ),
        (
            vec![
                "twin",
                "gtn",
                "--test",
                "data/tensile/P91_20_2_DF_SS.csv",
                "--param",
                "q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1",
                "--mesh",
                "100000x100000",
            ],
            "1 to 64 radial",
        ),
        (
            vec!["record", "--iface", "vcan0", "--duration=-5s"],
            "duration such as",
        ),
    ] {
        let message = refused(&args, 2);
        assert!(message.contains(said), "{args:?}: {message}");
    }
    assert!(!root().join("x.csv").exists());
}

// ---- DBC: an error for what cannot be decoded, one warning for what looks wrong ------------

#[test]
fn a_dbc_that_cannot_be_decoded_is_refused_and_a_suspicious_one_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let log = root().join("fixtures/logs/excavator_case1.log");
    let head = "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: DAQ\n\n";
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    for (name, text, said) in [
        ("empty.dbc", String::new(), "empty.dbc"),
        ("nothing.dbc", head.to_string(), "no messages"),
        (
            "long.dbc",
            format!("{head}BO_ 256 Probe: 200 DAQ\n SG_ X : 0|8@1+ (1,0) [0|0] \"\" DAQ\n"),
            "at most 64",
        ),
        (
            "huge.dbc",
            format!("{head}BO_ 256 Probe: 8 DAQ\n SG_ X : 0|16@1+ (1e308,0) [0|0] \"\" DAQ\n"),
            "overflow",
        ),
    ] {
        let dbc = write(name, &text);
        let message = refused(
            &["decode", path_arg(&log), "--dbc", path_arg(&dbc), "-o", "-"],
            2,
        );
        assert!(message.contains(said), "{name}: {message}");
    }
    let odd = write(
        "odd.dbc",
        &format!(
            "{head}BO_ 256 Probe: 8 DAQ\n SG_ A : 0|8@1+ (1,0) [0|0] \"\" DAQ\n SG_ B : 4|8@1+ (1,0) [0|0] \"\" DAQ\n\
             BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n SG_ Orphan : 0|8@1+ (1,0) [0|0] \"\" DAQ\n"
        ),
    );
    let output = acq(&["decode", path_arg(&log), "--dbc", path_arg(&odd), "-o", "-"]);
    let message = stderr(&output);
    assert!(output.status.success(), "{message}");
    assert_eq!(
        message.matches("A and B share bits").count(),
        1,
        "{message}"
    );
    assert!(
        !message.contains("VECTOR__INDEPENDENT_SIG_MSG"),
        "{message}"
    );
}

// ---- a study checks its inputs before its first model run ---------------------------------

#[test]
fn a_study_that_cannot_work_is_refused_before_its_first_run() {
    let dir = tempfile::tempdir().unwrap();
    let case = std::fs::read_to_string(root().join("data/excavator/case1.toml")).unwrap();
    for (from, to, said) in [
        (
            "bucket_stroke_mm = [116, 126]",
            "bucket_stroke_mm = [121, 121]",
            "lower < upper",
        ),
        ("boom_bar = 73.35", "boom_bar = 0", "measured boom pressure"),
        (
            "bucket_stroke_mm = [116, 126]",
            "bucket_stroke_mm = [116, 5000]",
            "corner",
        ),
    ] {
        let text = case.replace(from, to);
        assert_ne!(text, case);
        let path = dir.path().join("case.toml");
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join("calibration");
        let message = refused(
            &[
                "calibrate",
                "excavator",
                "--case",
                path_arg(&path),
                "--out",
                path_arg(&out),
            ],
            2,
        );
        assert!(message.contains(said), "{to}: {message}");
        assert!(!out.exists(), "{to}: the run directory was made");
    }

    // Every solver run fails: the first failure is said, and where the rest is.
    let spec = external_spec(
        dir.path(),
        &[(
            "command = [\"sh\", \"solver.sh\"",
            "command = [\"sh\", \"-c\", \"echo licence server down >&2; exit 7\", \"solver.sh\"",
        )],
    );
    let message = refused_external(&spec, &dir.path().join("failing"));
    assert!(
        message.contains("licence server down") && message.contains("exit status: 7"),
        "{message}"
    );
    assert!(
        message.contains("evaluations.csv") && message.contains("runs"),
        "{message}"
    );
}

/// A case file with another load case's measured values (wrong success:
/// Case 1's file with Case 2's session ran to a 65 % error, three inputs
/// on their bounds): the measured load is not the case's force, and it is
/// refused before any run, both ways round. A case that bounds its force
/// takes any load inside the bounds.
#[test]
fn a_case_file_with_another_cases_measured_values_is_refused_before_any_run() {
    let dir = tempfile::tempdir().unwrap();
    let measured = |session: &str| {
        let out = dir.path().join(format!("{session}.csv"));
        let session = root().join("fixtures/sessions").join(session);
        let output = acq(&["extract", path_arg(&session), "-o", path_arg(&out)]);
        assert!(output.status.success(), "{}", stderr(&output));
        out
    };
    let (one, two) = (measured("excavator_case1"), measured("excavator_case2"));
    let calibrate = |case: &Path, values: &Path, out: &Path| {
        let mut args = vec!["calibrate", "excavator", "--case", path_arg(case)];
        args.extend(["--measured", path_arg(values), "--out", path_arg(out)]);
        args.extend(["--training", "12", "--test-runs", "1"]);
        args.extend(["--population", "4", "--generations", "1"]);
        acq(&args)
    };
    for (case, values, load, stated) in [
        ("case1", &two, "24.6", "40.6"),
        ("case2", &one, "40.6", "24.6"),
    ] {
        let out = dir.path().join(format!("{case}-out"));
        let case = root().join(format!("data/excavator/{case}.toml"));
        let output = calibrate(&case, values, &out);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{message}");
        assert!(
            message.contains("another load case")
                && message.contains(&format!("tip_force is {load}"))
                && message.contains(&format!("force_kN = {stated} kN")),
            "{message}"
        );
        assert!(!out.exists(), "the run directory was made");
    }
    // Case 1's file that calibrates the force over [20, 45] kN takes Case
    // 2's load (24.6 kN): no refusal.
    let case = std::fs::read_to_string(root().join("data/excavator/case1.toml")).unwrap();
    let bounded = case.replace(
        "force_angle_deg = [-15, -5]",
        "force_angle_deg = [-15, -5]\nforce_kN = [20, 45]",
    );
    assert_ne!(bounded, case);
    let path = dir.path().join("bounded.toml");
    std::fs::write(&path, bounded).unwrap();
    let output = calibrate(&path, &two, &dir.path().join("bounded-out"));
    assert!(output.status.success(), "{}", stderr(&output));
}

// ---- files read back: line numbers and what was expected ----------------------------------

#[test]
fn damaged_or_contradictory_files_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    // A measured-values file with one quantity twice in one window.
    let measured = dir.path().join("measured.csv");
    let extracted = acq(&[
        "extract",
        "fixtures/sessions/excavator_case2",
        "-o",
        path_arg(&measured),
    ]);
    assert!(extracted.status.success(), "{}", stderr(&extracted));
    let text = std::fs::read_to_string(&measured).unwrap();
    let second = text.lines().nth(1).unwrap().to_string();
    std::fs::write(&measured, format!("{text}{second}\n")).unwrap();
    let rows = text.lines().count() + 1;
    let message = refused(
        &[
            "calibrate",
            "excavator",
            "--case",
            "data/excavator/case2.toml",
            "--measured",
            path_arg(&measured),
            "--out",
            path_arg(&dir.path().join("c")),
        ],
        3,
    );
    assert!(
        message.contains(&format!("measured.csv:{rows}")) && message.contains("line 2"),
        "{message}"
    );

    // An ASC log whose date cannot be read.
    let asc = dir.path().join("bad-date.asc");
    std::fs::write(
        &asc,
        "date someday\nbase hex  timestamps absolute\n   0.001 1  123  Rx   d 1 00\n",
    )
    .unwrap();
    let message = refused(
        &[
            "decode",
            path_arg(&asc),
            "--rig",
            "fixtures/rigs/excavator.toml",
            "-o",
            "-",
        ],
        3,
    );
    assert!(
        message.contains("bad-date.asc:1") && message.contains("date header"),
        "{message}"
    );

    // A damaged evaluation log on --resume.
    let run = dir.path().join("resume");
    std::fs::create_dir(&run).unwrap();
    let small_run = [
        "calibrate",
        "excavator",
        "--case",
        "data/excavator/case1.toml",
        "--out",
        path_arg(&run),
        "--training",
        "6",
        "--test-runs",
        "3",
    ];
    let first = acq(&small_run);
    assert!(first.status.success(), "{}", stderr(&first));
    let log = run.join("evaluations.csv");
    let good = std::fs::read(&log).unwrap();
    for (damage, said) in [
        (
            b"3,ok,0.001,\xff\xfe,1,2,3,4,5,6,7,\n".to_vec(),
            "invalid UTF-8",
        ),
        (b"3,ok,0.001,1,2,3,4,NaN,6,7,\n".to_vec(), "not a number"),
    ] {
        let mut bytes = good.clone();
        let cut = bytes
            .iter()
            .enumerate()
            .filter(|(_, b)| **b == b'\n')
            .nth(2)
            .unwrap()
            .0;
        bytes.truncate(cut + 1);
        bytes.extend_from_slice(&damage);
        std::fs::write(&log, &bytes).unwrap();
        let resumed: Vec<&str> = small_run.iter().copied().chain(["--resume"]).collect();
        let message = refused(&resumed, 2);
        assert!(
            message.contains("evaluations.csv:4") && message.contains(said),
            "{message}"
        );
    }
}

/// A python-can BLF (shipped as a fuzz seed) and acq's own MF4 of the same
/// kind of log, and two text logs, each cut short: reading stops with exit
/// 3 and names the file and what was expected; --skip-bad keeps what was
/// read and says what is missing. Never "frames read N" and exit 0.
#[test]
fn a_log_cut_short_is_never_read_as_complete() {
    let dir = tempfile::tempdir().unwrap();
    let blf = std::fs::read(root().join("fuzz/seeds/blf_log/python_can_zlib.blf")).unwrap();
    let mf4 = std::fs::read(root().join("fuzz/seeds/mf4_log/acq.mf4")).unwrap();
    let candump =
        b"(1763719200.000100) can0 123#11223344\n(1763719200.000250) can0 123#1122".to_vec();
    let asc = b"date Tue Mar 4 09:15:02.512 am 2025\nbase hex  timestamps absolute\nBegin Triggerblock Tue Mar 4 09:15:02.512 am 2025\n   0.010214 1  181 Tx d 2 A0 0F\n".to_vec();
    let cuts: [(&str, Vec<u8>, &str); 6] = [
        // Inside the 144-byte file header, and inside an object's header.
        ("header.blf", blf[..100].to_vec(), "a whole file header"),
        (
            "object.blf",
            blf[..blf.len() - 9].to_vec(),
            "a whole object",
        ),
        ("data.mf4", mf4[..mf4.len() - 10].to_vec(), "expected"),
        ("meta.mf4", mf4[..200].to_vec(), "expected"),
        ("cut.log", candump, "a line ended by a newline"),
        ("cut.asc", asc, "an 'End TriggerBlock' line"),
    ];
    for (name, bytes, expected) in cuts {
        let log = dir.path().join(name);
        std::fs::write(&log, &bytes).unwrap();
        let message = refused(
            &[
                "decode",
                path_arg(&log),
                "--dbc",
                "fixtures/dbc/tensile_frame.dbc",
            ],
            3,
        );
        assert!(
            message.contains(path_arg(&log)) && message.contains(expected),
            "{name}: {message}"
        );
        // Kept on request, and the cut is reported; a cut before the
        // first frame leaves nothing, which is never a success.
        let output = acq(&[
            "decode",
            path_arg(&log),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
            "--skip-bad",
        ]);
        // (object.blf: its frames are in one zlib container, which a cut
        // leaves unreadable whole; data.mf4: its one data block, which the
        // reader refuses whole when the file ends inside it.)
        let nothing_left = matches!(name, "header.blf" | "object.blf" | "data.mf4" | "meta.mf4");
        let code = if nothing_left { 3 } else { 0 };
        assert_eq!(
            output.status.code(),
            Some(code),
            "{name}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains("acq: skipped"),
            "{name}: {}",
            stderr(&output)
        );
        assert_eq!(
            stderr(&output).contains(&format!("{}: no CAN frame read from it", path_arg(&log))),
            nothing_left,
            "{name}: {}",
            stderr(&output)
        );
    }
    // A BLF that ends between objects before the size its header states
    // (as a copy stopped at an object boundary would) says how much is
    // missing: here the header claims 100 bytes more than the file has.
    let mut short = blf.clone();
    let stated = u64::from_le_bytes(short[16..24].try_into().unwrap());
    assert_eq!(
        stated,
        blf.len() as u64,
        "python-can states the file's size"
    );
    short[16..24].copy_from_slice(&(stated + 100).to_le_bytes());
    let log = dir.path().join("short.blf");
    std::fs::write(&log, &short).unwrap();
    let message = refused(
        &[
            "decode",
            path_arg(&log),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
        ],
        3,
    );
    assert!(message.contains("(100 missing)"), "{message}");
}

/// A decode that stops at a malformed line leaves nothing under the
/// output's name, whatever the format (stdout still streams).
#[test]
fn a_failed_decode_leaves_no_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("broken.log");
    std::fs::write(
        &log,
        "(1.000000) can0 200#0000000000000000\n(2.000000) can0 200#00112\n(3.000000) can0 200#0000000000000000\n",
    )
    .unwrap();
    for name in ["out.csv", "out.parquet", "out.mf4"] {
        let out = dir.path().join(name);
        let message = refused(
            &[
                "decode",
                path_arg(&log),
                "--dbc",
                "fixtures/dbc/tensile_frame.dbc",
                "-o",
                path_arg(&out),
            ],
            3,
        );
        assert!(
            message.contains("broken.log:2:") && message.contains("is not written"),
            "{name}: {message}"
        );
        assert_eq!(files_in(dir.path()), ["broken.log"], "{name}");
    }
}

/// Each message names the real mistake, not a consequence of it.
#[test]
fn messages_name_the_real_mistake() {
    let dir = tempfile::tempdir().unwrap();
    // Bounds the wrong way round, or not a number: the bounds are named,
    // not the nominal they leave outside.
    for (lower, upper) in [("10.0", "0.0"), ("nan", "10.0"), ("0.0", "inf")] {
        let spec = external_spec(
            dir.path(),
            &[(
                "lower = 0.0\nupper = 10.0",
                &format!("lower = {lower}\nupper = {upper}"),
            )],
        );
        let message = refused_external(&spec, &dir.path().join("run"));
        assert!(
            message.contains("parameter x_mm: lower =")
                && message.contains("finite bounds with lower below upper"),
            "{message}"
        );
        assert!(!message.contains("nominal"), "{message}");
    }
    // A tensile test whose displacement never changes, or runs backwards.
    for (name, rows, expected) in [
        ("flat.csv", "0,0\n0,1\n0,2\n0,3\n", "never changes"),
        (
            "backwards.csv",
            "0,0\n-0.1,2\n-0.2,4\n-0.3,5\n-0.4,4\n",
            "runs backwards",
        ),
    ] {
        let test = dir.path().join(name);
        std::fs::write(&test, format!("DISPLACEMENT,FORCE\n{rows}")).unwrap();
        let message = refused(&["tensile-props", path_arg(&test)], 3);
        assert!(
            message.contains(expected) && message.contains("displacement"),
            "{message}"
        );
    }
    // A displacement sensor given as the force, and a force as the
    // extensometer: their kinds and units from the rig.
    let session = "fixtures/sessions/tensile_p91_20c";
    let message = refused(
        &["extract", session, "--tensile", "--force", "extension"],
        2,
    );
    assert!(
        message.contains("--force extension")
            && message.contains("displacement sensor in mm")
            && message.contains("force sensors: load"),
        "{message}"
    );
    let message = refused(
        &["extract", session, "--tensile", "--displacement", "load"],
        2,
    );
    assert!(message.contains("force sensor in kN"), "{message}");
    // A negative weight is a weight, refused as one.
    for weights in [&["1", "1", "-1"][..], &["1,1,-1"], &["-1,1,1"], &["1", "1"]] {
        let mut args = vec![
            "calibrate",
            "excavator",
            "--case",
            "data/excavator/case1.toml",
        ];
        let out = dir.path().join("weights");
        args.extend(["--out", path_arg(&out), "--weights"]);
        args.extend(weights);
        let message = refused(&args, 2);
        assert!(
            message.contains("give three weights") && message.contains("non-negative"),
            "{message}"
        );
        assert!(!out.exists());
    }
    // A Slurm time limit sbatch would refuse for every job is refused with
    // the spec, before the run directory exists.
    for limit in ["1:2:3:4", "1:75", "3-25:00", "--5"] {
        let spec = external_spec(
            dir.path(),
            &[(
                "parallel = 2\n",
                &format!(
                    "\n[executor]\nkind = \"slurm\"\nparallel = 2\ntime_limit = \"{limit}\"\n"
                ),
            )],
        );
        let out = dir.path().join("slurm");
        let message = refused_external(&spec, &out);
        assert!(
            message.contains("time_limit") && message.contains("D-HH:MM:SS"),
            "{limit}: {message}"
        );
        assert!(!out.exists());
    }
}

/// The evaluated points and their outputs, sorted (ids follow the finish
/// order within a batch of parallel runs).
fn evaluated(out: &Path) -> Vec<String> {
    let log = std::fs::read_to_string(out.join("evaluations.csv")).unwrap();
    let mut rows: Vec<String> = log
        .lines()
        .skip(1)
        .map(|line| {
            let cells: Vec<&str> = line.split(',').collect();
            // Without id and wall_s: the point and what the model gave.
            cells[1..2]
                .iter()
                .chain(&cells[3..])
                .copied()
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    rows.sort();
    rows
}

/// With two simulations at once, the default lets whichever finishes
/// first steer the next point; --deterministic runs synchronous batches,
/// so the same command gives the same search, point for point.
#[test]
fn a_run_with_several_slots_is_reproducible_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let runs: Vec<PathBuf> = (0..2)
        .map(|k| {
            let out = dir.path().join(format!("run{k}"));
            let output = acq(&[
                "calibrate",
                "gtn",
                "--test",
                "data/tensile/P91_20_2_DF_SS.csv",
                "--out",
                path_arg(&out),
                "--mesh",
                "3x12",
                "--max-evals",
                "18",
                "--target-mape",
                "0",
                "--batch",
                "2",
                "--deterministic",
            ]);
            assert!(output.status.success(), "{}", stderr(&output));
            out
        })
        .collect();
    let summary = |out: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
    };
    let (first, second) = (summary(&runs[0]), summary(&runs[1]));
    assert_eq!(first["best_params"], second["best_params"]);
    assert_eq!(first["best_mape"], second["best_mape"]);
    assert_eq!(evaluated(&runs[0]), evaluated(&runs[1]));
    assert_eq!(evaluated(&runs[0]).len(), 18);
}

/// A measured curve its metric cannot score is refused when the spec is
/// read, before any model run: a constant force under DTW (no range to
/// normalise by) and a curve that goes back in x under MAPE (no function
/// of x to interpolate). Nothing runs: no evaluations.csv.
#[test]
fn a_measured_curve_its_metric_cannot_score_is_refused_before_any_run() {
    for (rows, metric, says) in [
        (
            (1..=10)
                .map(|i| format!("{},5.0\n", 0.5 * f64::from(i)))
                .collect::<String>(),
            "dtw",
            "cannot be scored by dtw",
        ),
        (
            (1..=10)
                .map(|i| {
                    format!(
                        "{},{}\n",
                        if i % 2 == 0 {
                            0.5 * f64::from(i)
                        } else {
                            5.0 - 0.4 * f64::from(i)
                        },
                        f64::from(i)
                    )
                })
                .collect::<String>(),
            "mape",
            "cannot be scored by mape",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let spec = common::parabola_study(
            dir.path(),
            "start = \"lhs\"\nstart_runs = 4\nmax_evals = 6\n",
        );
        std::fs::write(
            dir.path().join("test.csv"),
            format!("DISPLACEMENT,FORCE\n{rows}"),
        )
        .unwrap();
        let text = std::fs::read_to_string(&spec).unwrap().replace(
            "measured_y = \"FORCE\"",
            &format!("measured_y = \"FORCE\"\nmetric = \"{metric}\""),
        );
        std::fs::write(&spec, text).unwrap();
        let out = dir.path().join("run");
        let message = refused_external(&spec, &out);
        assert!(message.contains(says), "{metric}: {message}");
        assert!(
            !out.join("evaluations.csv").exists(),
            "{metric}: a model ran"
        );
    }
}

/// A study at the rig without `[candidates]` is still checked against
/// the twin before anything is read or recorded: an input or an output the
/// twin does not have, or a gauge past its gauges, is refused with what
/// the twin has (exit 2), instead of a study whose every hold is "not
/// used". The example study without its candidates still loads.
#[test]
fn a_rig_study_without_candidates_is_checked_against_the_twin() {
    let dir = tempfile::tempdir().unwrap();
    let session = copy_session("excavator_case1", dir.path());
    let example = example_rig_study();
    let without_candidates = &example[..example.find("\n[candidates]").unwrap()];
    let study = dir.path().join("study.toml");
    let run = |text: &str| {
        std::fs::write(&study, text).unwrap();
        acq(&[
            "calibrate",
            "rig",
            path_arg(&session),
            "--study",
            path_arg(&study),
            "-o",
            path_arg(&dir.path().join("state.json")),
        ])
    };
    let fine = run(without_candidates);
    assert!(fine.status.success(), "{}", stderr(&fine));
    for (from, to, says) in [
        (
            "force_kN = \"tip_force\"",
            "force_kn = \"tip_force\"",
            "takes no input \"force_kn\"",
        ),
        (
            "\"gauge_stress_MPa[9]\"",
            "\"gauge_stress_MPa[99]\"",
            "no output \"gauge_stress_MPa[99]\"",
        ),
        (
            "\"cylinder_force_kN.boom\"",
            "\"cylinder_force_kN.stick\"",
            "no output \"cylinder_force_kN.stick\"",
        ),
    ] {
        let bad = without_candidates.replace(from, to);
        assert_ne!(bad, without_candidates, "{from}");
        let output = run(&bad);
        assert_eq!(output.status.code(), Some(2), "{to}: {}", stderr(&output));
        assert!(stderr(&output).contains(says), "{to}: {}", stderr(&output));
    }
}

/// The example study at the rig, its geometry's path made absolute (so it
/// loads from a temporary directory).
fn example_rig_study() -> String {
    std::fs::read_to_string(root().join("examples/excavator-rig/study.toml"))
        .unwrap()
        .replace(
            "geometry = \"../../data/excavator/dx55.toml\"",
            &format!("geometry = {:?}", root().join("data/excavator/dx55.toml")),
        )
}

/// A spec's parameters and weights are refused where they could only
/// give NaN or nothing, each naming the key and the fix: bounds of 1e308
/// (their range overflows), a log scale from 0, a prior's value outside
/// the bounds where no nominal was written, every weight 0, and a
/// posterior's refinement budget past a thousand model runs.
#[test]
fn a_specs_parameters_and_weights_that_give_nan_or_nothing_are_refused_by_name() {
    for (from, to, says) in [
        ("lower = 1.0\nupper = 3.0", "lower = -1e308\nupper = 1e308", "at most 1e100 in size"),
        ("lower = 1.0\nupper = 3.0", "lower = 0.0\nupper = 3.0\nscale = \"log\"", "scale = \"log\" needs lower above 0"),
        ("lower = 1.0\nupper = 3.0", "lower = 1.0\nupper = 3.0\nprior = { value = 100.0, uncertainty = 1.0 }", "the prior's value (the nominal where none is given) = 100 lies outside the bounds 1 .. 3"),
        ("measured_y = \"FORCE\"", "measured_y = \"FORCE\"\nweight = 0.0", "every measured value and curve has weight 0"),
        ("max_evals = 6", "max_evals = 6\n\n[posterior]\nrefinement_runs = 5000", "posterior.refinement_runs = 5000: at most 1000"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let spec = common::parabola_study(dir.path(), "start = \"lhs\"\nstart_runs = 4\nmax_evals = 6\n");
        let text = std::fs::read_to_string(&spec).unwrap();
        assert!(text.contains(from), "{from}");
        std::fs::write(&spec, text.replace(from, to)).unwrap();
        let out = dir.path().join("run");
        let message = refused_external(&spec, &out);
        assert!(message.contains(says), "{to}: {message}");
        assert!(!out.join("evaluations.csv").exists(), "{to}: a model ran");
    }
}

/// A session's raw log damaged after recording: read as the candump acq
/// record wrote (its lines reported as candump, not guessed to be another
/// format), refused when it holds none of the frames session.toml counts
/// (replaced by other bytes, or emptied), and said when it holds fewer.
#[test]
fn a_session_log_damaged_after_recording_is_named_against_its_count() {
    let dir = tempfile::tempdir().unwrap();
    let session = copy_session("tensile_p91_20c", dir.path());
    let raw = session.join("raw.log");
    let original = std::fs::read_to_string(&raw).unwrap();
    let counted = original.lines().count();
    // Bytes of another kind (a text that is no log), then nothing at all.
    let other: String = (0..200)
        .map(|k| format!("line {k} of some other file\n"))
        .collect();
    for (what, text) in [("replaced", other.as_str()), ("emptied", "")] {
        std::fs::write(&raw, text).unwrap();
        let message = refused(&["extract", path_arg(&session), "--tensile"], 3);
        assert!(
            message.contains(&format!(
                "holds no frame where session.toml counts {counted}"
            )) && message.contains("restore raw.log"),
            "{what}: {message}"
        );
        assert!(
            !message.contains("Triggerblock"),
            "{what}: read as ASC: {message}"
        );
        if what == "replaced" {
            assert!(
                message.contains("200 line(s) could not be read as candump"),
                "{message}"
            );
            // Each bad line is not reported one by one past the first ten.
            assert!(message.matches("acq: skipped").count() <= 10, "{message}");
        }
    }
    // Cut to its first half: read, and the cut said once.
    let half: String = original
        .lines()
        .take(counted / 2)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&raw, half).unwrap();
    let output = acq(&["extract", path_arg(&session), "--tensile"]);
    let message = stderr(&output);
    assert!(output.status.success(), "{message}");
    let said = format!(
        "holds {} frames where session.toml counts {counted}",
        counted / 2
    );
    assert_eq!(message.matches(&said).count(), 1, "{message}");
}

/// Messages that name the form a value takes and the fix: a `[candidates]`
/// entry of the wrong form, a posterior whose emulator the search's budget
/// cannot feed, an empty measured curve (not a "design").
#[test]
fn messages_name_the_form_and_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let session = copy_session("excavator_case1", dir.path());
    let example = example_rig_study();
    let forces = "force_kN = [5.0, 20.0, 40.0]";
    assert!(example.contains(forces));
    let study = dir.path().join("study.toml");
    for (given, says) in [
        (
            "force_kN = { from = 5.0, to = 40.0, steps = -3 }",
            "steps = -3: give a whole number",
        ),
        (
            "force_kN = [5.0, \"twenty\"]",
            "value 2 = \"twenty\" is not a number",
        ),
        (
            "force_kN = { from = 5.0, to = 40.0, steps = 3, step = 1 }",
            "unknown key \"step\"",
        ),
        ("force_kN = \"all\"", "neither a list nor a range"),
    ] {
        std::fs::write(&study, example.replace(forces, given)).unwrap();
        let message = refused(
            &[
                "calibrate",
                "rig",
                path_arg(&session),
                "--study",
                path_arg(&study),
            ],
            2,
        );
        assert!(
            message.contains(says) && message.contains("{ from = 5.0, to = 40.0, steps = 8 }"),
            "{given}: {message}"
        );
        assert!(!message.contains("untagged"), "{message}");
    }
    // Two parameters need four runs for the posterior's emulator; a search
    // of three is refused before it starts.
    let spec = common::parabola_study(
        dir.path(),
        "start = \"lhs\"\nstart_runs = 2\nmax_evals = 3\n",
    );
    let text = std::fs::read_to_string(&spec)
        .unwrap()
        .replace("\"{a}\"]", "\"{a}\", \"{b}\"]")
        .replace(
            "[[curve]]",
            "[[parameter]]\nname = \"b\"\nlower = 0.0\nupper = 1.0\n\n[[curve]]",
        );
    std::fs::write(&spec, format!("{text}\n[posterior]\ndraws = 100\n")).unwrap();
    let out = dir.path().join("run");
    let message = refused_external(&spec, &out);
    assert!(
        message.contains("needs at least 4") && message.contains("search.max_evals = 3"),
        "{message}"
    );
    assert!(
        !out.join("evaluations.csv").exists(),
        "a model ran: {message}"
    );
    // A measured curve with its header alone.
    let spec = common::parabola_study(
        dir.path(),
        "start = \"lhs\"\nstart_runs = 2\nmax_evals = 3\n",
    );
    std::fs::write(dir.path().join("test.csv"), "DISPLACEMENT,FORCE\n").unwrap();
    let output = calibrate_external(&spec, &dir.path().join("empty"), &[]);
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(3), "malformed input: {message}");
    assert!(
        message.contains("test.csv")
            && message
                .contains("a header but no rows of values; add one row per point of the curve"),
        "{message}"
    );
    assert!(!message.contains("design"), "{message}");
}

/// What acq says of itself is true: `--help` names every format decode and
/// convert read, and a command that takes no rig, given a log, does not
/// suggest a `--rig` it would refuse.
#[test]
fn help_and_suggestions_are_true_to_the_commands() {
    let output = acq(&["--help"]);
    let help = common::stdout(&output);
    for command in ["decode", "convert"] {
        let line = help
            .lines()
            .find(|l| l.trim_start().starts_with(command))
            .unwrap_or_else(|| panic!("{command} in {help}"));
        for format in ["candump", "ASC", "BLF", "MF4"] {
            assert!(line.contains(format), "{command}: {line}");
        }
    }
    let log = "fixtures/sessions/tensile_p91_20c/raw.log";
    for args in [
        &[
            "calibrate",
            "rig",
            log,
            "--study",
            "examples/excavator-rig/study.toml",
        ][..],
        &["zero", log, "--before", "1s"],
        &["view", log],
    ] {
        let message = refused(args, 2);
        assert!(message.contains("session directory"), "{args:?}: {message}");
        assert!(!message.contains("--rig"), "{args:?}: {message}");
    }
}

/// A logger's file is told by its content, whatever its name: a CANedge
/// container is refused naming the tool that converts it, binary data of
/// no known format is not taken for ASC, an unfinalized MF4 whose flags
/// leave nothing to recover reads as the finalized file does, and one
/// whose last block's length was never written reads to the file's end.
#[test]
fn a_logger_s_file_is_told_by_its_content() {
    let dir = tempfile::tempdir().unwrap();
    let decode = |log: &Path| {
        acq(&[
            "decode",
            path_arg(log),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
        ])
    };
    let mut container = b"Generic File".to_vec();
    container.extend_from_slice(&[1, 0, 0x22, 0x01, 0, 0, 0, 7, 0, 0, 0, 4, 0, 0, 1, 0]);
    container.extend_from_slice(&[0x55; 64]);
    let mfc = dir.path().join("00000001.MFC");
    std::fs::write(&mfc, &container).unwrap();
    let message = refused(
        &[
            "decode",
            path_arg(&mfc),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
        ],
        3,
    );
    assert!(
        message.contains(&format!(
            "{}: byte offset 0: expected a CAN log acq reads",
            path_arg(&mfc)
        )) && message.contains("compressed MF4 container")
            && message.contains("mdf2finalized"),
        "{message}"
    );
    let elf = dir.path().join("program.asc");
    std::fs::write(&elf, b"\x7fELF\x02\x01\x01\x00\x00\x00\x00\x00").unwrap();
    let message = refused(
        &[
            "decode",
            path_arg(&elf),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
        ],
        3,
    );
    assert!(
        message.contains("binary data (first bytes 7f 45 4c 46"),
        "{message}"
    );

    let finalized = std::fs::read(root().join("fuzz/seeds/mf4_log/acq.mf4")).unwrap();
    let mut unfinalized = finalized.clone();
    unfinalized[..8].copy_from_slice(b"UnFinMF ");
    let (ours, theirs) = (dir.path().join("final.mf4"), dir.path().join("unfin.mf4"));
    std::fs::write(&ours, &finalized).unwrap();
    std::fs::write(&theirs, &unfinalized).unwrap();
    let (read, read_unfinalized) = (decode(&ours), decode(&theirs));
    assert!(
        read_unfinalized.status.success(),
        "{}",
        stderr(&read_unfinalized)
    );
    assert!(!read.stdout.is_empty());
    assert_eq!(read.stdout, read_unfinalized.stdout);
    // Flags at byte 60: the last data block's length (0x04) and cycle
    // counts (0x01) not written, as a logger cut off leaves them: the last
    // `##DT` runs to the file's end, whatever length it states.
    unfinalized[60..62].copy_from_slice(&0x05u16.to_le_bytes());
    let dt = unfinalized
        .windows(4)
        .rposition(|id| id == b"##DT")
        .unwrap();
    unfinalized[dt + 8..dt + 16].copy_from_slice(&24u64.to_le_bytes());
    std::fs::write(&theirs, &unfinalized).unwrap();
    let recovered = decode(&theirs);
    assert!(recovered.status.success(), "{}", stderr(&recovered));
    assert_eq!(read.stdout, recovered.stdout);
    // Cut inside its last record: every whole record is read, and the cut
    // is named. The same cut in a finalized file is malformed.
    let records_end = dt
        + usize::try_from(u64::from_le_bytes(
            finalized[dt + 8..dt + 16].try_into().unwrap(),
        ))
        .unwrap();
    let frames = |log: &Path| {
        let out = dir.path().join("frames.log");
        let converted = acq(&["convert", path_arg(log), "-o", path_arg(&out)]);
        assert!(converted.status.success(), "{}", stderr(&converted));
        let text = std::fs::read_to_string(&out).unwrap();
        (
            text.lines().map(str::to_owned).collect::<Vec<_>>(),
            stderr(&converted),
        )
    };
    let (all, _) = frames(&ours);
    std::fs::write(&theirs, &unfinalized[..records_end - 3]).unwrap();
    let (before_cut, told) = frames(&theirs);
    assert!(
        told.contains("unfinalized MF4 cut off inside a record"),
        "{told}"
    );
    assert!(
        before_cut.len() + 1 == all.len() && all.starts_with(&before_cut),
        "{before_cut:?} of {all:?}"
    );
    std::fs::write(&ours, &finalized[..records_end - 3]).unwrap();
    let message = refused(
        &[
            "decode",
            path_arg(&ours),
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
        ],
        3,
    );
    assert!(message.contains("expected a whole"), "{message}");
}

/// Data lost: a link standing at the name of a temporary file acq writes
/// (`.zero.toml.tmp` in a session) or at an output's name is never written
/// through. A symbolic link to a file outside the session and a hard link
/// to the session's recording both stay as they were; the zero record is a
/// file of its own. An output named by a symbolic link is refused (exit
/// 2); one that is a hard link is replaced, its other name keeping what it
/// held.
#[test]
fn a_link_at_a_temporary_or_an_output_name_is_never_written_through() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case2", dir.path());
    let outside = dir.path().join("outside.txt");
    std::fs::write(&outside, "a file outside the session\n").unwrap();
    let temporary = session.join(".zero.toml.tmp");
    std::os::unix::fs::symlink(&outside, &temporary).unwrap();
    let zeroed = acq(&["zero", path_arg(&session), "--before", "0.5s"]);
    assert!(zeroed.status.success(), "{}", stderr(&zeroed));
    assert_eq!(
        std::fs::read_to_string(&outside).unwrap(),
        "a file outside the session\n"
    );
    let zero = std::fs::symlink_metadata(session.join("zero.toml")).unwrap();
    assert!(zero.is_file(), "zero.toml is a file of its own: {zero:?}");

    let raw = session.join("raw.log");
    let recording = std::fs::read(&raw).unwrap();
    std::fs::hard_link(&raw, &temporary).unwrap();
    let zeroed = acq(&["zero", path_arg(&session), "--before", "0.5s"]);
    assert!(zeroed.status.success(), "{}", stderr(&zeroed));
    assert!(
        std::fs::read(&raw).unwrap() == recording,
        "the recording kept"
    );
    assert!(std::fs::read_to_string(session.join("zero.toml"))
        .unwrap()
        .contains("before_s"));

    // Outputs: a symbolic link is refused, the file it names untouched.
    let linked = dir.path().join("linked.csv");
    std::os::unix::fs::symlink(&outside, &linked).unwrap();
    let refused = acq(&["extract", path_arg(&session), "-o", path_arg(&linked)]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(
        stderr(&refused).contains("does not write through links"),
        "{}",
        stderr(&refused)
    );
    assert_eq!(
        std::fs::read_to_string(&outside).unwrap(),
        "a file outside the session\n"
    );
    // A hard link is replaced: its other name keeps what it held.
    let kept = dir.path().join("kept.csv");
    std::fs::write(&kept, "kept\n").unwrap();
    let out = dir.path().join("out.csv");
    std::fs::hard_link(&kept, &out).unwrap();
    let extracted = acq(&["extract", path_arg(&session), "-o", path_arg(&out)]);
    assert!(extracted.status.success(), "{}", stderr(&extracted));
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), "kept\n");
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .starts_with("window,"));
}

/// A path escape and a copy changed by hand: a session's rig copy that
/// names a sensor file outside its folder is refused before anything reads
/// that file (`acq zero` used its range), and a copy whose bytes are no
/// longer those session.toml recorded is refused, naming both, with the
/// way out (`--rig`).
#[test]
fn a_sessions_rig_copy_is_the_one_recorded_and_names_only_files_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("outside");
    std::fs::create_dir(&outside).unwrap();
    std::fs::write(outside.join("sensors.toml"), "# outside\n").unwrap();
    let session = common::copy_session("excavator_case2", dir.path());
    let rig_copy = session.join("rig/excavator.toml");
    let text = std::fs::read_to_string(&rig_copy).unwrap();
    let escaped = format!(
        "[rig]\nsensor_file = \"../../outside/sensors.toml\"\n{}",
        text.replacen("[rig]\n", "", 1)
    );
    std::fs::write(&rig_copy, escaped).unwrap();
    for command in [
        vec!["zero", path_arg(&session), "--before", "0.5s"],
        vec!["extract", path_arg(&session), "-o", "-"],
    ] {
        let refused = acq(&command);
        assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
        let told = stderr(&refused);
        assert!(
            told.contains("outside the session's rig folder") && told.contains("--rig RIG.toml"),
            "{told}"
        );
    }
    assert!(!session.join("zero.toml").exists());

    // A session written now records its copy's own hash: an edit is seen.
    let mf4 = dir.path().join("00000001.MF4");
    let converted = acq(&[
        "convert",
        path_arg(&session.join("raw.log")),
        "-o",
        path_arg(&mf4),
    ]);
    assert!(converted.status.success(), "{}", stderr(&converted));
    let imported = dir.path().join("imported");
    let made = acq(&[
        "import",
        path_arg(&mf4),
        "--rig",
        path_arg(&root().join("fixtures/sessions/excavator_case2/rig/excavator.toml")),
        "--out",
        path_arg(&imported),
    ]);
    assert!(made.status.success(), "{}", stderr(&made));
    let ok = acq(&["extract", path_arg(&imported), "-o", "-"]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    let copy = imported.join("rig/excavator.toml");
    let edited =
        std::fs::read_to_string(&copy)
            .unwrap()
            .replacen("rate_hz = 100", "rate_hz = 50", 1);
    std::fs::write(&copy, edited).unwrap();
    let refused = acq(&["extract", path_arg(&imported), "-o", "-"]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    let told = stderr(&refused);
    assert!(
        told.contains("rig/excavator.toml: not the bytes")
            && told.contains("session.toml recorded"),
        "{told}"
    );
    // The way out the message gives works.
    let with_rig = acq(&[
        "extract",
        path_arg(&imported),
        "--rig",
        path_arg(&copy),
        "-o",
        "-",
    ]);
    assert!(with_rig.status.success(), "{}", stderr(&with_rig));
}

/// Harmful advice, round four: a rig file saved in a session under the
/// name of a record acq keeps there (`shunt.toml`, `zero.toml`) is named
/// for what it is, with exit 2, never answered with "remove it" (which
/// would delete the rig); the rig is left as it was.
#[test]
fn a_rig_at_a_records_name_is_named_for_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case2", dir.path());
    let rig_text = std::fs::read(session.join("rig/excavator.toml")).unwrap();
    for name in ["shunt.toml", "zero.toml"] {
        let placed = session.join(name);
        std::fs::write(&placed, &rig_text).unwrap();
        let output = acq(&["extract", path_arg(&session), "-o", "-"]);
        let told = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{name}: {told}");
        assert!(
            told.contains(&format!("{name}: this is a rig file")) && !told.contains("remove it"),
            "{name}: {told}"
        );
        assert_eq!(std::fs::read(&placed).unwrap(), rig_text, "{name} kept");
        std::fs::remove_file(&placed).unwrap();
    }
}

//! The evaluation log: every evaluation logged as it finishes, failures
//! never fatal, and a resumed run answered from the log bit for bit.

use std::sync::atomic::{AtomicUsize, Ordering};

use acq_algorithms::evaluation::{
    validate_parameters, EvaluationError, Evaluator, Parameter, Simulator,
};

/// `y = (a + b, a * b)`; fails for a < 0, panics for a > 100, returns NaN
/// for b = 7. Counts its calls.
struct Toy {
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    calls: AtomicUsize,
}

impl Toy {
    fn new() -> Self {
        Toy {
            parameters: vec![
                Parameter::new("a_mm", -10.0, 200.0),
                Parameter::new("b_deg", 0.0, 10.0),
            ],
            outputs: vec!["sum".into(), "product".into()],
            calls: AtomicUsize::new(0),
        }
    }
}

impl Simulator for Toy {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        assert!(x[0] <= 100.0, "a = {} is beyond the model", x[0]);
        if x[0] < 0.0 {
            return Err("negative a, \"quoted\",\nand a second line".into());
        }
        if x[1] == 7.0 {
            return Ok(vec![f64::NAN, 1.0]);
        }
        Ok(vec![x[0] + x[1], x[0] * x[1]])
    }
}

fn points(seed: u64, n: usize) -> Vec<Vec<f64>> {
    // Awkward decimals, so the log must round-trip them exactly.
    (0..n)
        .map(|i| {
            let t = (seed as f64 + i as f64) * std::f64::consts::PI;
            vec![t.sin().abs() * 50.0 + 0.1, (t.cos().abs() * 9.0) / 3.0]
        })
        .collect()
}

#[test]
fn failures_are_logged_with_their_reason_and_never_end_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("evaluations.csv");
    let toy = Toy::new();
    let mut evaluator = Evaluator::create(&toy, &path, 3).unwrap();
    let batch = vec![
        vec![1.0, 2.0],
        vec![-1.0, 2.0],
        vec![150.0, 1.0],
        vec![3.0, 7.0],
        vec![4.0, 0.5],
    ];
    let results = evaluator.evaluate(&batch).unwrap();
    assert_eq!(results.len(), 5);
    assert_eq!(results[0].outcome, Ok(vec![3.0, 2.0]));
    assert!(results[1]
        .outcome
        .as_ref()
        .unwrap_err()
        .contains("negative a"));
    assert!(results[2]
        .outcome
        .as_ref()
        .unwrap_err()
        .contains("panicked: a = 150 is beyond the model"));
    assert!(results[3]
        .outcome
        .as_ref()
        .unwrap_err()
        .contains("output sum is not finite"));
    assert_eq!(results[4].outcome, Ok(vec![4.5, 2.0]));
    for (i, r) in results.iter().enumerate() {
        assert_eq!(r.parameters, batch[i]);
    }
    let mut ids: Vec<usize> = results.iter().map(|r| r.id).collect();
    ids.sort_unstable();
    assert_eq!(ids, [1, 2, 3, 4, 5]);

    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "id,status,wall_s,a_mm,b_deg,sum,product,reason");
    assert_eq!(lines.len(), 6);
    // The log is in id order, whatever order the workers finished in.
    for (k, line) in lines[1..].iter().enumerate() {
        assert!(line.starts_with(&format!("{},", k + 1)), "{line}");
    }
    let failed = lines.iter().find(|l| l.contains("negative a")).unwrap();
    assert!(
        failed.ends_with(",,,\"negative a, \"\"quoted\"\", and a second line\""),
        "{failed}"
    );
}

#[test]
fn a_resumed_run_repeats_no_finished_evaluation_and_gives_the_same_results() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("evaluations.csv");
    let batches = [points(1, 4), points(10, 3), points(20, 5)];

    // The whole run, uninterrupted, without a log.
    let reference_toy = Toy::new();
    let mut reference = Evaluator::in_memory(&reference_toy, 2).unwrap();
    let mut expected = Vec::new();
    for batch in &batches {
        expected.extend(reference.evaluate(batch).unwrap());
    }

    // Interrupted after two batches...
    let first = Toy::new();
    {
        let mut evaluator = Evaluator::create(&first, &path, 2).unwrap();
        evaluator.evaluate(&batches[0]).unwrap();
        evaluator.evaluate(&batches[1]).unwrap();
    }
    assert_eq!(first.calls.load(Ordering::SeqCst), 7);
    // ... and a crash in the middle of writing a line.
    let mut text = std::fs::read_to_string(&path).unwrap();
    text.push_str("8,ok,0.1,3.0");
    std::fs::write(&path, &text).unwrap();

    // Creating over it is refused; resuming continues it.
    assert!(matches!(
        Evaluator::create(&Toy::new(), &path, 2),
        Err(EvaluationError::LogExists { .. })
    ));
    let second = Toy::new();
    let mut evaluator = Evaluator::resume(&second, &path, 2).unwrap();
    let mut resumed = Vec::new();
    for batch in &batches {
        resumed.extend(evaluator.evaluate(batch).unwrap());
    }
    assert_eq!(
        second.calls.load(Ordering::SeqCst),
        5,
        "only the third batch runs"
    );
    assert_eq!(evaluator.reused(), 7);
    assert_eq!(resumed.len(), expected.len());
    for (got, want) in resumed.iter().zip(&expected) {
        assert_eq!(got.parameters, want.parameters);
        assert_eq!(got.outcome, want.outcome, "bit for bit");
    }
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().count(), 1 + 12);
    assert!(!text.contains("8,ok,0.1,3.0\n9"), "the cut line is gone");
    let ids: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    let expected_ids: Vec<String> = (1..=12).map(|i| i.to_string()).collect();
    assert_eq!(ids, expected_ids);
}

#[test]
fn a_log_of_another_setup_or_a_damaged_log_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("evaluations.csv");
    std::fs::write(&path, "id,status,wall_s,x,reason\n").unwrap();
    let error = Evaluator::resume(&Toy::new(), &path, 1)
        .err()
        .unwrap()
        .to_string();
    assert!(
        error.contains("evaluations.csv:1: this log is of another setup"),
        "{error}"
    );

    std::fs::write(
        &path,
        "id,status,wall_s,a_mm,b_deg,sum,product,reason\n1,ok,0.1,1,2,3,x,\n",
    )
    .unwrap();
    let error = Evaluator::resume(&Toy::new(), &path, 1)
        .err()
        .unwrap()
        .to_string();
    assert!(
        error.contains("evaluations.csv:2: cell 7 (\"x\") is not a number"),
        "{error}"
    );
}

#[test]
fn bad_parameters_are_setup_errors() {
    let mut toy = Toy::new();
    toy.parameters[1] = Parameter::new("a_mm", 0.0, 1.0);
    let error = Evaluator::in_memory(&toy, 1).err().unwrap().to_string();
    assert!(error.contains("listed twice"), "{error}");
    for (lower, upper) in [(2.0, 1.0), (1.0, 1.0), (f64::NAN, 1.0)] {
        toy.parameters[1] = Parameter::new("b", lower, upper);
        let error = Evaluator::in_memory(&toy, 1).err().unwrap().to_string();
        assert!(error.contains("lower < upper"), "{lower}..{upper}: {error}");
    }
    let toy = Toy::new();
    let mut evaluator = Evaluator::in_memory(&toy, 1).unwrap();
    let error = evaluator.evaluate(&[vec![1.0]]).err().unwrap().to_string();
    assert!(error.contains("takes 2"), "{error}");
}

#[test]
fn a_log_scale_parameter_moves_in_equal_ratios() {
    use acq_algorithms::evaluation::Scale;
    let p = Parameter::new("f0", 1e-4, 1e-2).with_scale(Scale::Log);
    // The middle of 1e-4 .. 1e-2 on a log scale is their geometric mean, 1e-3;
    // a quarter of the way is 10^-3.5.
    assert!((p.midpoint() - 1e-3).abs() < 1e-15);
    assert!((p.from_unit(0.25) - 10f64.powf(-3.5)).abs() < 1e-15);
    for u in [0.0, 0.1, 0.5, 0.9, 1.0] {
        assert!((p.to_unit(p.from_unit(u)) - u).abs() < 1e-12, "{u}");
    }
    let zero_lower = Parameter::new("x", 0.0, 1.0).with_scale(Scale::Log);
    let message = validate_parameters(&[zero_lower]).unwrap_err().to_string();
    assert!(message.contains("log scale needs lower > 0"), "{message}");
}

/// `y = x`, after sleeping `x` ms; counts its calls.
struct Sleepy {
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    calls: AtomicUsize,
}

impl Simulator for Sleepy {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        std::thread::sleep(std::time::Duration::from_millis(x[0] as u64));
        Ok(vec![x[0]])
    }
}

/// A search whose next point depends on which run finished: it starts
/// three, then after each result starts `10 * (results so far) + that
/// result's value mod 7`, up to 9 runs. Returns the points in the order
/// they finished.
fn order_dependent_search(evaluator: &mut Evaluator<'_>) -> Vec<f64> {
    evaluator.run_async(2, |runs| {
        for x in [60.0, 5.0, 30.0] {
            runs.start(vec![x]).unwrap();
        }
        let mut finished = Vec::new();
        let mut started = 3;
        while let Some(done) = runs.next_done().unwrap() {
            let x = done.parameters[0];
            finished.push(x);
            if started < 9 {
                runs.start(vec![10.0 * finished.len() as f64 + x % 7.0])
                    .unwrap();
                started += 1;
            }
        }
        finished
    })
}

#[test]
fn runs_as_they_finish_are_logged_and_a_resume_replays_them_in_their_order() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("evaluations.csv");
    let sleepy = Sleepy {
        parameters: vec![Parameter::new("x_ms", 0.0, 200.0)],
        outputs: vec!["y".into()],
        calls: AtomicUsize::new(0),
    };
    let first = {
        let mut evaluator = Evaluator::create(&sleepy, &log, 2).unwrap();
        let order = order_dependent_search(&mut evaluator);
        assert_eq!(evaluator.evaluations().len(), 9);
        order
    };
    assert_eq!(sleepy.calls.load(Ordering::SeqCst), 9);
    // Two slots: the 5 ms run ends before the 60 ms one that started with it.
    assert_eq!(first[0], 5.0, "{first:?}");
    assert_eq!(
        std::fs::read_to_string(&log).unwrap().lines().count(),
        10,
        "a header and nine runs"
    );
    // Resumed, every point comes from the log in the order it was written,
    // so the search takes the same path and the simulator is never called.
    let resumed = Sleepy {
        parameters: sleepy.parameters.clone(),
        outputs: sleepy.outputs.clone(),
        calls: AtomicUsize::new(0),
    };
    let mut evaluator = Evaluator::resume(&resumed, &log, 2).unwrap();
    let second = order_dependent_search(&mut evaluator);
    assert_eq!(first, second);
    assert_eq!(resumed.calls.load(Ordering::SeqCst), 0);
    assert!(evaluator.evaluations().iter().all(|e| e.from_log));
}

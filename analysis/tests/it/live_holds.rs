//! The live hold stream against `acq extract` on the same samples: the
//! shipped sessions (one hold each, recorded through a real vcan) and a
//! synthetic load history with holds at three levels, where the batch
//! rule's threshold (1 % of the range so far) grows while recording.

use std::path::PathBuf;

use acq_analysis::extract::holds::{HoldOptions, BLOCK_NS};
use acq_analysis::extract::live::LiveHoldStream;
use acq_analysis::extract::run::{extract_holds, WindowChoice};
use acq_analysis::recording::{Recording, SampleCounts};
use acq_rig::sensors::Sample;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/sessions")
        .join(name)
}

#[test]
fn live_holds_equal_extract_on_the_shipped_sessions() {
    for name in ["excavator_case1", "excavator_case2"] {
        let recording = Recording::open(&fixture(name), None).unwrap();
        let offline = extract_holds(
            &recording,
            &WindowChoice::Auto(HoldOptions::default()),
            None,
            &[],
        )
        .unwrap();
        let t0 = recording.session_start_unix_ns().unwrap();
        let mut live =
            LiveHoldStream::new(&recording.rig, None, HoldOptions::default(), t0).unwrap();
        // Live decoding applies no offset itself: the stream removes the rig's.
        let zero = vec![0; recording.rig.buses.len()];
        let mut counts = SampleCounts::default();
        // When (sample time) each hold was first reported, as the view would.
        let mut reported_at: Vec<i64> = Vec::new();
        let mut samples = 0u64;
        recording
            .for_each_sample(&zero, &mut counts, |sample| {
                let time = sample.time_ns;
                live.push(sample);
                samples += 1;
                // About every 20 ms of a 2,000 samples/s session, like a status tick.
                if samples % 40 == 0 && live.update() {
                    while reported_at.len() < live.holds().len() {
                        reported_at.push(time);
                    }
                }
                Ok(())
            })
            .unwrap();
        let closed_while_streaming = live.holds().len();
        live.finish();
        assert_eq!(live.revisions, 0, "{name}: a reported hold changed");
        let windows: Vec<_> = live.holds().iter().map(|h| h.window.clone()).collect();
        assert_eq!(windows, offline.windows, "{name}: windows");
        assert_eq!(
            closed_while_streaming,
            windows.len(),
            "{name}: each hold is reported before the session ends"
        );
        let values: Vec<_> = live
            .holds()
            .iter()
            .flat_map(|h| h.values.clone().expect("kept"))
            .collect();
        assert_eq!(values, offline.values, "{name}: values, bit for bit");
        for (hold, at) in windows.iter().zip(&reported_at) {
            // The steady run ends `settle` after the window; the rolling
            // window's half (0.5 s) and one block later it is final.
            let delay_s = (at - hold.end_ns) as f64 / 1e9;
            assert!(
                (0.0..=1.2).contains(&delay_s),
                "{name}: {} reported {delay_s:.2} s after its end",
                hold.name
            );
        }
    }
}

/// Idle, then holds at 20, 40 and 10 (kN) of 6 s each with 2 s ramps and
/// 3 s idles, 100 Hz, a little noise: the second hold doubles the range.
fn three_levels() -> Vec<(i64, f64)> {
    let mut series = Vec::new();
    let mut t = 0.0f64;
    let mut level = 0.0;
    let mut push = |duration: f64, target: f64, t: &mut f64, level: &mut f64| {
        let steps = (duration * 100.0) as usize;
        let from = *level;
        for i in 0..steps {
            let x = (i + 1) as f64 / steps as f64;
            let value = from + (target - from) * x.min(1.0);
            // Deterministic "noise": a few hundredths, never steady-breaking.
            let wiggle = 0.01 * ((*t * 37.0).sin() + (*t * 91.0).cos());
            series.push(((*t * 1e9) as i64, value + wiggle));
            *t += 0.01;
        }
        *level = target;
    };
    push(3.0, 0.0, &mut t, &mut level);
    for target in [20.0, 40.0, 10.0] {
        push(2.0, target, &mut t, &mut level);
        push(6.0, target, &mut t, &mut level);
        push(2.0, 0.0, &mut t, &mut level);
        push(3.0, 0.0, &mut t, &mut level);
    }
    series
}

#[test]
fn three_levels_while_the_range_grows_end_equal_to_the_batch_rule() {
    let recording = Recording::open(&fixture("excavator_case1"), None).unwrap();
    let rig = &recording.rig;
    let load = rig.sensor("tip_force").unwrap().0;
    let t0 = 1_000_000_000_000;
    for options in [
        HoldOptions::default(),
        HoldOptions {
            steady_std: Some(0.2),
            ..HoldOptions::default()
        },
    ] {
        let mut live = LiveHoldStream::new(rig, None, options, t0).unwrap();
        let mut batch = acq_analysis::extract::holds::HoldDetector::default();
        for (time, value) in three_levels() {
            let sample = Sample {
                time_ns: t0 + time,
                sensor: load,
                value: Some(value),
            };
            live.push(sample);
            batch.push(sample.time_ns, value);
            if time % BLOCK_NS == 0 {
                live.update();
            }
        }
        live.finish();
        eprintln!("{options:?}: {} revisions", live.revisions);
        let windows: Vec<_> = live.holds().iter().map(|h| h.window.clone()).collect();
        assert_eq!(windows, batch.detect(&options).holds, "{options:?}");
        assert_eq!(windows.len(), 3, "{windows:?}");
        for hold in live.holds() {
            let values = hold.values.as_ref().unwrap();
            let force = values.iter().find(|v| v.quantity == "tip_force").unwrap();
            let mean = force.stats.mean.unwrap();
            assert!(
                [20.0, 40.0, 10.0].iter().any(|l| (mean - l).abs() < 0.05),
                "{mean}"
            );
        }
        if options.steady_std.is_some() {
            // A fixed threshold: nothing reported is ever taken back.
            assert_eq!(live.revisions, 0);
        }
    }
}

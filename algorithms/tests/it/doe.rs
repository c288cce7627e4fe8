//! Designs of experiments: stratification, space filling, published sequences and arrays,
//! and the CSV reader's errors.

use acq_algorithms::doe::{
    full_factorial, latin_hypercube, min_pairwise_distance, orthogonal_array_l12,
    random_latin_hypercube, random_uniform, read_design_csv, scale_to_bounds, scale_to_unit,
    sobol_points, two_level_to_unit, DoeError,
};
use proptest::prelude::*;

/// Each column holds exactly one point per stratum [k/n, (k+1)/n).
fn assert_latin(points: &[Vec<f64>], n: usize, dimensions: usize) {
    assert_eq!(points.len(), n);
    for column in 0..dimensions {
        let mut strata: Vec<usize> = points
            .iter()
            .map(|p| {
                assert!((0.0..1.0).contains(&p[column]), "{}", p[column]);
                (p[column] * n as f64).floor() as usize
            })
            .collect();
        strata.sort_unstable();
        assert_eq!(strata, (0..n).collect::<Vec<_>>(), "column {column}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn latin_hypercube_has_one_point_per_stratum(
        n in 1_usize..60,
        dimensions in 1_usize..7,
        seed in any::<u64>(),
    ) {
        let points = latin_hypercube(n, dimensions, seed);
        assert_latin(&points, n, dimensions);
        prop_assert!(points.iter().all(|p| p.len() == dimensions));
        assert_latin(&random_latin_hypercube(n, dimensions, seed), n, dimensions);
    }
}

#[test]
fn latin_hypercube_strata_survive_rounding() {
    // 1/49 * 49 rounds below 1: the stratum nudge must catch it.
    assert_latin(&latin_hypercube(49, 3, 0), 49, 3);
    assert_latin(&latin_hypercube(1_000, 2, 1), 1_000, 2);
}

#[test]
fn maximin_beats_a_plain_latin_hypercube() {
    for seed in 0..8 {
        let optimised = min_pairwise_distance(&latin_hypercube(20, 3, seed));
        let plain: Vec<f64> = (0..20)
            .map(|k| min_pairwise_distance(&random_latin_hypercube(20, 3, seed * 100 + k)))
            .collect();
        let best_plain = plain.iter().copied().fold(0.0, f64::max);
        assert!(
            optimised > best_plain,
            "seed {seed}: {optimised} vs best of 20 plain {best_plain}"
        );
    }
}

#[test]
fn designs_are_reproducible_by_seed() {
    assert_eq!(latin_hypercube(15, 4, 3), latin_hypercube(15, 4, 3));
    assert_ne!(latin_hypercube(15, 4, 3), latin_hypercube(15, 4, 4));
    assert_eq!(random_uniform(10, 2, 8), random_uniform(10, 2, 8));
    assert_ne!(random_uniform(10, 2, 8), random_uniform(10, 2, 9));
    assert!(random_uniform(100, 3, 1)
        .iter()
        .flatten()
        .all(|v| (0.0..1.0).contains(v)));
    assert_eq!(
        sobol_points(16, 3, Some(5)).unwrap(),
        sobol_points(16, 3, Some(5)).unwrap()
    );
    assert_ne!(
        sobol_points(16, 3, Some(5)).unwrap(),
        sobol_points(16, 3, Some(6)).unwrap()
    );
}

#[test]
fn degenerate_latin_hypercubes() {
    assert!(latin_hypercube(0, 3, 1).is_empty());
    assert_eq!(latin_hypercube(4, 0, 1), vec![Vec::<f64>::new(); 4]);
    assert_latin(&latin_hypercube(1, 2, 1), 1, 2);
    assert_latin(&latin_hypercube(2, 2, 1), 2, 2);
    assert_eq!(min_pairwise_distance(&[vec![0.5]]), f64::INFINITY);
}

#[test]
fn unscrambled_sobol_matches_joe_kuo() {
    // The first points of the Joe-Kuo new-joe-kuo-6.21201 sequence in Gray-code order, as
    // printed by scipy.stats.qmc.Sobol(5, scramble=False).random(8) (scipy 1.x).
    let published = [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.5, 0.5, 0.5, 0.5, 0.5],
        [0.75, 0.25, 0.25, 0.25, 0.75],
        [0.25, 0.75, 0.75, 0.75, 0.25],
        [0.375, 0.375, 0.625, 0.875, 0.375],
        [0.875, 0.875, 0.125, 0.375, 0.875],
        [0.625, 0.125, 0.875, 0.625, 0.625],
        [0.125, 0.625, 0.375, 0.125, 0.125],
    ];
    let points = sobol_points(8, 5, None).unwrap();
    for (point, expected) in points.iter().zip(&published) {
        assert_eq!(point.as_slice(), expected.as_slice());
    }
    // The larger tables load for more dimensions.
    assert_eq!(sobol_points(4, 150, None).unwrap()[1], vec![0.5; 150]);
}

#[test]
fn scrambled_sobol_keeps_one_point_per_stratum() {
    // Owen scrambling keeps a power-of-two prefix a net: each 1-D stratum once.
    let n = 64;
    let points = sobol_points(n, 6, Some(42)).unwrap();
    assert_latin(&points, n, 6);
    // And moves off the origin.
    assert!(points[0].iter().any(|&v| v > 0.0));
}

#[test]
fn sobol_errors() {
    assert_eq!(sobol_points(4, 0, None), Err(DoeError::NoDimensions));
    assert!(matches!(
        sobol_points(4, 21_202, None),
        Err(DoeError::SobolDimensions { .. })
    ));
    assert!(matches!(
        sobol_points(4, 257, Some(1)),
        Err(DoeError::SobolDimensions { .. })
    ));
    assert!(matches!(
        sobol_points(65_537, 2, Some(1)),
        Err(DoeError::SobolPoints { .. })
    ));
    let message = sobol_points(65_537, 2, Some(1)).unwrap_err().to_string();
    assert!(message.contains("pass no seed"), "{message}");
}

#[test]
fn l12_first_eight_columns_are_the_published_calibration_runs() {
    // The 12 runs over 8 parameters of the published excavator calibration.
    let published = [
        "11111111", "11111222", "11222111", "12122122", "12212212", "12221221", "21221122",
        "21212221", "21122212", "22211112", "22121211", "22112121",
    ];
    let runs = orthogonal_array_l12(8).unwrap();
    let as_text: Vec<String> = runs
        .iter()
        .map(|run| run.iter().map(|level| level.to_string()).collect())
        .collect();
    assert_eq!(as_text, published);
    // They are the first 8 columns of the full 11-column array.
    let full = orthogonal_array_l12(11).unwrap();
    for (short, long) in runs.iter().zip(&full) {
        assert_eq!(short.as_slice(), &long[..8]);
    }
}

#[test]
fn l12_is_orthogonal() {
    let array = orthogonal_array_l12(11).unwrap();
    assert_eq!(array.len(), 12);
    for a in 0..11 {
        assert_eq!(array.iter().filter(|run| run[a] == 1).count(), 6);
        for b in (a + 1)..11 {
            for combination in [(1, 1), (1, 2), (2, 1), (2, 2)] {
                let count = array
                    .iter()
                    .filter(|run| (run[a], run[b]) == combination)
                    .count();
                assert_eq!(count, 3, "columns {a} and {b}, levels {combination:?}");
            }
        }
    }
    assert_eq!(
        orthogonal_array_l12(0),
        Err(DoeError::L12Factors { factors: 0 })
    );
    assert_eq!(
        orthogonal_array_l12(12),
        Err(DoeError::L12Factors { factors: 12 })
    );
}

#[test]
fn two_levels_map_to_the_box_corners() {
    let unit = two_level_to_unit(&orthogonal_array_l12(3).unwrap());
    assert_eq!(unit[0], vec![0.0, 0.0, 0.0]);
    assert_eq!(unit[1], vec![0.0, 0.0, 0.0]);
    assert_eq!(unit[3], vec![0.0, 1.0, 0.0]);
    assert_eq!(unit[9], vec![1.0, 1.0, 1.0]);
}

#[test]
fn full_factorial_counts_and_levels() {
    let design = full_factorial(&[3, 2]).unwrap();
    assert_eq!(
        design,
        vec![
            vec![0.0, 0.0],
            vec![0.0, 1.0],
            vec![0.5, 0.0],
            vec![0.5, 1.0],
            vec![1.0, 0.0],
            vec![1.0, 1.0],
        ]
    );
    assert_eq!(full_factorial(&[1]).unwrap(), vec![vec![0.5]]);
    assert_eq!(full_factorial(&[2, 3, 4, 5]).unwrap().len(), 120);
    assert_eq!(full_factorial(&[]), Err(DoeError::NoDimensions));
    assert_eq!(
        full_factorial(&[2, 0]),
        Err(DoeError::ZeroLevels { dimension: 1 })
    );
    assert!(matches!(
        full_factorial(&[usize::MAX, 2]),
        Err(DoeError::TooManyRuns { .. })
    ));
    assert!(matches!(
        full_factorial(&[10; 8]),
        Err(DoeError::TooManyRuns { .. })
    ));
}

#[test]
fn scaling_round_trips() {
    let bounds = [(10.0, 20.0), (-1.0, 1.0), (5.0, 5.0)];
    let physical = scale_to_bounds(&[0.25, 0.5, 0.7], &bounds);
    assert_eq!(physical, vec![12.5, 0.0, 5.0]);
    assert_eq!(scale_to_unit(&physical, &bounds), vec![0.25, 0.5, 0.5]);
}

const DESIGN: &str = "\
run, stiffness ,damping,notes
1, 2.5, 0.1, first
2, 3.5, 0.2, \"second, with a comma\"

3, 4.5, 0.3, third
";

#[test]
fn csv_design_selects_columns_by_name_in_the_given_order() {
    let design = read_design_csv(DESIGN, &["damping", "stiffness"]).unwrap();
    assert_eq!(design, vec![vec![0.1, 2.5], vec![0.2, 3.5], vec![0.3, 4.5]]);
    let with_bom = format!("\u{feff}{DESIGN}");
    assert_eq!(read_design_csv(&with_bom, &["run"]).unwrap().len(), 3);
}

fn csv_error(text: &str, names: &[&str]) -> (u64, String) {
    match read_design_csv(text, names) {
        Err(DoeError::Csv { line, message }) => (line, message),
        other => panic!("expected a CSV error, got {other:?}"),
    }
}

#[test]
fn csv_design_errors_name_the_line_and_the_expectation() {
    let (line, message) = csv_error(DESIGN, &["stiffness", "mass"]);
    assert_eq!(line, 1);
    assert!(message.contains("no column 'mass'"), "{message}");

    let (line, message) = csv_error("a,b\n1,2\n3,x\n", &["a", "b"]);
    assert_eq!(line, 3);
    assert!(
        message.contains("'b' must be a finite number, found 'x'"),
        "{message}"
    );

    // An empty cell is an error too; a line of only separators is a blank line.
    for bad in ["NaN", "inf", "-infinity", ""] {
        let (line, message) = csv_error(&format!("a,b\n1,2\n{bad},2\n"), &["a"]);
        assert_eq!(line, 3, "{bad}");
        assert!(message.contains("finite number"), "{message}");
    }
    assert_eq!(
        read_design_csv("a,b\n1,2\n,\n", &["a"]).unwrap(),
        vec![vec![1.0]]
    );

    let (line, message) = csv_error("a,b,c\n1,2,3\n4,5\n", &["c"]);
    assert_eq!(line, 3);
    assert!(message.contains("only 2 fields"), "{message}");

    let (line, message) = csv_error("a,a\n1,2\n", &["a"]);
    assert_eq!(line, 1);
    assert!(message.contains("more than once"), "{message}");

    let (_, message) = csv_error("a,b\n", &["a"]);
    assert!(
        message.contains("no rows of values; add one row per run"),
        "{message}"
    );
    let (line, _) = csv_error("", &["a"]);
    assert_eq!(line, 1);
    let (_, message) = csv_error("a\n1\n", &[]);
    assert!(message.contains("no column names"), "{message}");
}

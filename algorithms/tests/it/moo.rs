//! NSGA-II, non-dominated sorting, crowding and hypervolume against hand-made sets, closed
//! forms, the ZDT/DTLZ benchmarks and pymoo.

use acq_algorithms::moo::{
    crowding_distance, environmental_selection, fast_non_dominated_sort, hypervolume, nsga2,
    MooError, Nsga2Result, Nsga2Settings, Problem, Tournament,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// pymoo 0.6.2 NSGA2 (pop 100, 250 generations, default operators), mean over seeds 1..5 of
/// the final front's hypervolume for reference point (1.1, 1.1). Produced by
/// `/tmp/pymoo-venv/bin/python algorithms/tests/golden/pymoo_zdt.py` (venv with `pip install
/// pymoo`); per-seed values and wall times are in that script's output, recorded here:
///   zdt1: mean 0.869776 (min 0.869624), 1.085 s per run
///   zdt2: mean 0.536283 (min 0.535783), 1.217 s per run
///   zdt3: mean 1.327689 (min 1.327333), 1.085 s per run
const PYMOO_MEAN_HV: [(Problem, f64); 3] = [
    (Problem::Zdt1, 0.869_776),
    (Problem::Zdt2, 0.536_283),
    (Problem::Zdt3, 1.327_689),
];

fn settings(population: usize, generations: usize, seed: u64) -> Nsga2Settings {
    Nsga2Settings {
        population,
        generations,
        seed,
        ..Nsga2Settings::default()
    }
}

fn front_objectives(result: &Nsga2Result) -> Vec<Vec<f64>> {
    result.front.iter().map(|i| i.objectives.clone()).collect()
}

fn run(problem: Problem, settings: &Nsga2Settings) -> Nsga2Result {
    nsga2(|x| problem.evaluate(x), &problem.bounds(), settings).expect("valid settings")
}

#[test]
fn non_dominated_sort_of_a_hand_made_set() {
    let points = vec![
        vec![1.0, 4.0],      // 0: front 0
        vec![2.0, 2.0],      // 1: front 0
        vec![4.0, 1.0],      // 2: front 0
        vec![3.0, 3.0],      // 3: dominated by 1
        vec![4.0, 4.0],      // 4: dominated by 3 (and 1, 2)
        vec![5.0, 5.0],      // 5: dominated by 4
        vec![f64::NAN, 0.0], // 6: a failed evaluation, dominated by everything finite
        vec![2.0, 2.0],      // 7: a clone of 1: neither dominates the other
    ];
    let fronts = fast_non_dominated_sort(&points);
    assert_eq!(
        fronts,
        vec![vec![0, 1, 2, 7], vec![3], vec![4], vec![5], vec![6]]
    );
    assert!(fast_non_dominated_sort(&[]).is_empty());
}

/// Fronts by the definition: peel off the non-dominated set again and again.
fn fronts_by_definition(points: &[Vec<f64>]) -> Vec<Vec<usize>> {
    let dominates = |a: &[f64], b: &[f64]| {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        match (finite(a), finite(b)) {
            (true, false) => true,
            (false, _) => false,
            (true, true) => {
                a.iter().zip(b).all(|(x, y)| x <= y) && a.iter().zip(b).any(|(x, y)| x < y)
            }
        }
    };
    let mut left: Vec<usize> = (0..points.len()).collect();
    let mut fronts = Vec::new();
    while !left.is_empty() {
        let front: Vec<usize> = left
            .iter()
            .copied()
            .filter(|&i| !left.iter().any(|&j| dominates(&points[j], &points[i])))
            .collect();
        left.retain(|i| !front.contains(i));
        fronts.push(front);
    }
    fronts
}

proptest::proptest! {
    #[test]
    fn non_dominated_sort_matches_the_definition(
        raw in proptest::collection::vec(proptest::collection::vec(0_u8..6, 3), 0..40),
        objectives in 1_usize..=3,
    ) {
        // Small integer grids make ties, clones and long dominance chains common; 5 marks
        // a failed evaluation.
        let points: Vec<Vec<f64>> = raw
            .iter()
            .map(|row| row[..objectives].iter().map(|&v| if v == 5 { f64::NAN } else { f64::from(v) }).collect())
            .collect();
        proptest::prop_assert_eq!(fast_non_dominated_sort(&points), fronts_by_definition(&points));
    }
}

#[test]
fn crowding_distance_of_a_hand_made_front() {
    // Ranges 5 and 5. (1,3): f1 neighbours 0 and 3 -> 3/5, f2 neighbours 2 and 5 -> 3/5.
    // (3,2): f1 neighbours 1 and 5 -> 4/5, f2 neighbours 0 and 3 -> 3/5.
    let front: Vec<&[f64]> = vec![&[0.0, 5.0], &[1.0, 3.0], &[3.0, 2.0], &[5.0, 0.0]];
    let distance = crowding_distance(&front);
    assert_eq!(distance[0], f64::INFINITY);
    assert_eq!(distance[3], f64::INFINITY);
    assert!((distance[1] - 1.2).abs() < 1e-12, "{distance:?}");
    assert!((distance[2] - 1.4).abs() < 1e-12, "{distance:?}");

    // Two members: both extremes. A clone counts once. A failure gets 0.
    assert_eq!(
        crowding_distance(&[&[0.0, 1.0], &[1.0, 0.0]]),
        vec![f64::INFINITY; 2]
    );
    let with_clone: Vec<&[f64]> = vec![&[0.0, 2.0], &[1.0, 1.0], &[1.0, 1.0], &[2.0, 0.0]];
    let distance = crowding_distance(&with_clone);
    assert_eq!(distance[2], 0.0);
    assert!((distance[1] - 2.0).abs() < 1e-12, "{distance:?}");
    let with_failure: Vec<&[f64]> = vec![&[0.0, 1.0], &[f64::NAN, 0.5], &[1.0, 0.0]];
    assert_eq!(crowding_distance(&with_failure)[1], 0.0);
}

#[test]
fn environmental_selection_caps_the_first_front() {
    // Ten mutually non-dominated points on a line, and ten points each dominated by one.
    let front: Vec<Vec<f64>> = (0..10).map(|k| vec![k as f64, 9.0 - k as f64]).collect();
    let dominated: Vec<Vec<f64>> = front.iter().map(|p| vec![p[0] + 0.5, p[1] + 0.5]).collect();
    let pool: Vec<Vec<f64>> = front.iter().chain(&dominated).cloned().collect();

    let chosen = environmental_selection(&pool, 10, 0.5);
    assert_eq!(chosen.len(), 10);
    assert_eq!(chosen.iter().filter(|&&i| i < 10).count(), 5);
    // The extremes of the first front always survive the cut.
    assert!(chosen.contains(&0) && chosen.contains(&9));

    // Textbook NSGA-II: the whole first front.
    let chosen = environmental_selection(&pool, 10, 1.0);
    assert!(chosen.iter().all(|&i| i < 10));

    // Too few others to fill the rest: more come from the first front.
    let small_pool: Vec<Vec<f64>> = front.iter().chain(&dominated[..2]).cloned().collect();
    let chosen = environmental_selection(&small_pool, 10, 0.3);
    assert_eq!(chosen.iter().filter(|&&i| i < 10).count(), 8);
}

#[test]
fn pareto_fraction_keeps_dominated_individuals_in_a_run() {
    let problem = Problem::Zdt1;
    let capped = run(
        problem,
        &Nsga2Settings {
            pareto_fraction: 0.3,
            ..settings(100, 100, 3)
        },
    );
    let textbook = run(
        problem,
        &Nsga2Settings {
            pareto_fraction: 1.0,
            ..settings(100, 100, 3)
        },
    );
    // With the whole first front kept, a converged population is nearly all rank 0; with
    // the cap, most places go to later fronts every generation.
    assert!(textbook.front.len() >= 90, "{}", textbook.front.len());
    let capped_dominated = capped.population.iter().filter(|i| i.rank > 0).count();
    assert!(capped_dominated >= 40, "{capped_dominated}");
    assert_eq!(capped.population.len(), 100);
}

#[test]
fn hypervolume_two_objectives_closed_forms() {
    let single = hypervolume(&[vec![0.5, 0.5]], &[1.0, 1.0]).unwrap();
    assert!((single - 0.25).abs() < 1e-15);
    // Union of two rectangles: 0.32 + 0.32 - 0.16.
    let two = vec![vec![0.2, 0.6], vec![0.6, 0.2]];
    assert!((hypervolume(&two, &[1.0, 1.0]).unwrap() - 0.48).abs() < 1e-15);
    // A dominated point, a point beyond the reference and a failed one add nothing.
    let noisy = vec![
        vec![0.2, 0.6],
        vec![0.6, 0.2],
        vec![0.7, 0.7],
        vec![1.5, 0.1],
        vec![f64::NAN, 0.1],
        vec![f64::INFINITY, 0.0],
    ];
    assert!((hypervolume(&noisy, &[1.0, 1.0]).unwrap() - 0.48).abs() < 1e-15);
    assert_eq!(hypervolume(&[], &[1.0, 1.0]).unwrap(), 0.0);

    // ZDT1's true front: the area above f2 = 1 - sqrt(f1) in the unit square is 2/3, and
    // the reference (1.1, 1.1) adds the 1.1^2 - 1 = 0.21 margin.
    let front = Problem::Zdt1.pareto_front(100_001);
    let unit = hypervolume(&front, &[1.0, 1.0]).unwrap();
    assert!((unit - 2.0 / 3.0).abs() < 1e-4, "{unit}");
    let wide = hypervolume(&front, &[1.1, 1.1]).unwrap();
    assert!((wide - (2.0 / 3.0 + 0.21)).abs() < 1e-4, "{wide}");
    assert!((wide - Problem::Zdt1.true_hypervolume()).abs() < 1e-4);
    for problem in [Problem::Zdt2, Problem::Zdt3] {
        let dense =
            hypervolume(&problem.pareto_front(100_001), &problem.reference_point()).unwrap();
        assert!(
            (dense - problem.true_hypervolume()).abs() < 1e-4,
            "{problem:?} {dense}"
        );
    }
}

#[test]
fn hypervolume_three_objectives_closed_forms() {
    let single = hypervolume(&[vec![0.5, 0.5, 0.5]], &[1.0, 1.0, 1.0]).unwrap();
    assert!((single - 0.125).abs() < 1e-15);
    // Two boxes: 0.5 + 0.25 minus their overlap [0.5,1]^2 x [0.5,1] = 0.125.
    let two = vec![vec![0.0, 0.0, 0.5], vec![0.5, 0.5, 0.0]];
    assert!((hypervolume(&two, &[1.0, 1.0, 1.0]).unwrap() - 0.625).abs() < 1e-15);
    // Order does not matter, and a dominated point adds nothing.
    let shuffled = vec![
        vec![0.6, 0.6, 0.6],
        vec![0.5, 0.5, 0.0],
        vec![0.0, 0.0, 0.5],
    ];
    assert!((hypervolume(&shuffled, &[1.0, 1.0, 1.0]).unwrap() - 0.625).abs() < 1e-15);

    // DTLZ2's front is the unit sphere's octant: 1.1^3 - pi/6.
    let sphere = hypervolume(&Problem::Dtlz2.pareto_front(250_000), &[1.1, 1.1, 1.1]).unwrap();
    let truth = Problem::Dtlz2.true_hypervolume();
    assert!(
        (sphere - truth).abs() / truth < 0.005,
        "{sphere} vs {truth}"
    );
}

#[test]
fn hypervolume_three_objectives_matches_monte_carlo() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // Random points on a curved surface, so many are mutually non-dominated.
    let front: Vec<Vec<f64>> = (0..60)
        .map(|_| {
            let a: f64 = rng.random();
            let b: f64 = rng.random();
            vec![a, b, (1.0 - a.sqrt() * b.sqrt()).max(0.0) * 0.9 + 0.05]
        })
        .collect();
    let reference = [1.0, 1.0, 1.0];
    let exact = hypervolume(&front, &reference).unwrap();
    let samples = 400_000;
    let hits = (0..samples)
        .filter(|_| {
            let z = [
                rng.random::<f64>(),
                rng.random::<f64>(),
                rng.random::<f64>(),
            ];
            front
                .iter()
                .any(|p| p.iter().zip(&z).all(|(pi, zi)| pi <= zi))
        })
        .count();
    let estimate = hits as f64 / samples as f64;
    assert!(
        (exact - estimate).abs() / estimate < 0.01,
        "{exact} vs {estimate}"
    );
}

#[test]
fn hypervolume_errors() {
    assert!(matches!(
        hypervolume(&[vec![0.0, 0.0]], &[]),
        Err(MooError::InvalidReference { .. })
    ));
    assert!(matches!(
        hypervolume(&[vec![0.0, 0.0]], &[1.0, f64::NAN]),
        Err(MooError::InvalidReference { .. })
    ));
    assert!(matches!(
        hypervolume(&[vec![0.0, 0.0, 0.0]], &[1.0, 1.0]),
        Err(MooError::DimensionMismatch { index: 0, .. })
    ));
    assert!(matches!(
        hypervolume(&[vec![0.0, f64::NEG_INFINITY]], &[1.0, 1.0]),
        Err(MooError::UnboundedPoint { index: 0 })
    ));
    assert!(matches!(
        hypervolume(&[vec![0.0; 4]], &[1.0; 4]),
        Err(MooError::TooManyObjectives { objectives: 4 })
    ));
    // One objective: the distance from the best point to the reference.
    assert_eq!(hypervolume(&[vec![0.25], vec![0.5]], &[1.0]).unwrap(), 0.75);
}

#[test]
fn problems_parse_and_evaluate() {
    assert_eq!("ZDT1".parse::<Problem>().unwrap(), Problem::Zdt1);
    assert_eq!(" dtlz2 ".parse::<Problem>().unwrap(), Problem::Dtlz2);
    assert!(matches!(
        "zdt4".parse::<Problem>(),
        Err(MooError::UnknownProblem { .. })
    ));
    for problem in [Problem::Zdt1, Problem::Zdt2, Problem::Zdt3, Problem::Dtlz2] {
        assert_eq!(problem.name().parse::<Problem>().unwrap(), problem);
        assert_eq!(problem.bounds().len(), problem.variables());
        assert_eq!(
            problem.evaluate(&vec![0.3; problem.variables()]).len(),
            problem.objectives()
        );
        // Short or empty inputs do not panic.
        assert_eq!(problem.evaluate(&[]).len(), problem.objectives());
    }
    // On the Pareto set (distance variables at their optimum) the front's formula holds.
    let mut x = vec![0.0; 30];
    x[0] = 0.25;
    assert_eq!(Problem::Zdt1.evaluate(&x), vec![0.25, 0.5]);
    let on_sphere =
        Problem::Dtlz2.evaluate(&[0.3, 0.7, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
    let radius: f64 = on_sphere.iter().map(|f| f * f).sum::<f64>().sqrt();
    assert!((radius - 1.0).abs() < 1e-12);
}

#[test]
fn nsga2_reaches_the_zdt_fronts() {
    for problem in [Problem::Zdt1, Problem::Zdt2, Problem::Zdt3] {
        let result = run(
            problem,
            &Nsga2Settings {
                pareto_fraction: 1.0,
                ..settings(100, 250, 1)
            },
        );
        assert_eq!(result.evaluations, 100 * 251);
        let volume = hypervolume(&front_objectives(&result), &problem.reference_point()).unwrap();
        let truth = problem.true_hypervolume();
        assert!(volume >= 0.98 * truth, "{problem:?}: {volume} vs {truth}");
        for individual in &result.front {
            assert!(individual.x.iter().all(|v| (0.0..=1.0).contains(v)));
        }
    }
}

#[test]
fn nsga2_with_the_default_pareto_fraction_still_covers_zdt1() {
    let problem = Problem::Zdt1;
    let result = run(problem, &settings(100, 250, 1));
    let volume = hypervolume(&front_objectives(&result), &problem.reference_point()).unwrap();
    let truth = problem.true_hypervolume();
    assert!(volume >= 0.98 * truth, "{volume} vs {truth}");
}

#[test]
fn nsga2_is_not_worse_than_pymoo_on_zdt() {
    for (problem, pymoo_mean) in PYMOO_MEAN_HV {
        let seeds = 1..=5_u64;
        let total: f64 = seeds
            .clone()
            .map(|seed| {
                let result = run(
                    problem,
                    &Nsga2Settings {
                        pareto_fraction: 1.0,
                        tournament: Tournament::DominanceThenCrowding,
                        ..settings(100, 250, seed)
                    },
                );
                hypervolume(&front_objectives(&result), &problem.reference_point()).unwrap()
            })
            .sum();
        let ours = total / seeds.count() as f64;
        eprintln!("{problem:?}: ours {ours:.6}, pymoo {pymoo_mean:.6}");
        assert!(
            ours >= pymoo_mean * (1.0 - 0.005),
            "{problem:?}: mean HV {ours} below pymoo's {pymoo_mean} - 0.5 %"
        );
    }
}

/// ZDT3's front is five segments; its last (f1 from 0.82 to 0.85) is lost when the
/// population leaves that region while still far from the front. Tournaments by dominance
/// keep it: these are the first five seeds from 226 on where tournaments by rank lost it
/// (`acq moo --problem zdt3 --tournament rank`, 14 of seeds 226-525; by dominance 2).
#[test]
fn tournaments_by_dominance_keep_zdt3_s_last_segment() {
    for seed in [252, 281, 282, 289, 317] {
        let keeps_it = |tournament| {
            let result = run(
                Problem::Zdt3,
                &Nsga2Settings {
                    pareto_fraction: 1.0,
                    tournament,
                    ..settings(100, 250, seed)
                },
            );
            result.front.iter().any(|i| i.objectives[0] > 0.82)
        };
        assert!(keeps_it(Tournament::DominanceThenCrowding), "seed {seed}");
        assert!(
            !keeps_it(Tournament::RankThenCrowding),
            "seed {seed}, by rank"
        );
    }
}

#[test]
fn nsga2_puts_dtlz2_on_the_unit_sphere() {
    let problem = Problem::Dtlz2;
    let result = run(
        problem,
        &Nsga2Settings {
            pareto_fraction: 1.0,
            ..settings(100, 250, 2)
        },
    );
    assert!(result.front.len() >= 50);
    // The distance variables converge (g -> 0); the corners lag a little behind.
    let radii: Vec<f64> = result
        .front
        .iter()
        .map(|i| i.objectives.iter().map(|f| f * f).sum::<f64>().sqrt())
        .collect();
    let mean = radii.iter().sum::<f64>() / radii.len() as f64;
    assert!(mean - 1.0 < 0.01, "mean radius {mean}");
    for radius in radii {
        assert!((1.0 - 1e-12..1.05).contains(&radius), "radius {radius}");
    }
    // 100 points cannot cover the sphere's octant the way the continuous front does
    // (0.70 of its 0.807 with this seed); a collapsed or stuck front would score far less.
    let volume = hypervolume(&front_objectives(&result), &problem.reference_point()).unwrap();
    assert!(volume >= 0.8 * problem.true_hypervolume(), "{volume}");
}

#[test]
fn nsga2_is_reproducible_by_seed() {
    let problem = Problem::Zdt3;
    let a = run(problem, &settings(40, 30, 9));
    let b = run(problem, &settings(40, 30, 9));
    assert_eq!(a, b);
    let c = run(problem, &settings(40, 30, 10));
    assert_ne!(a, c);
}

#[test]
fn nsga2_gives_the_same_result_with_parallel_evaluation() {
    // A slow objective (50 us a call) is evaluated on all cores; a fast one with the same
    // values on the calling thread. The runs must not differ.
    let problem = Problem::Zdt2;
    let slow = |x: &[f64]| {
        let start = std::time::Instant::now();
        while start.elapsed() < std::time::Duration::from_micros(50) {
            std::hint::spin_loop();
        }
        problem.evaluate(x)
    };
    let parallel = nsga2(slow, &problem.bounds(), &settings(100, 3, 5)).unwrap();
    let sequential = run(problem, &settings(100, 3, 5));
    assert_eq!(parallel, sequential);
}

#[test]
fn nsga2_odd_population_and_zero_generations() {
    let problem = Problem::Zdt1;
    let result = run(problem, &settings(7, 3, 1));
    assert_eq!(result.population.len(), 7);
    assert_eq!(result.evaluations, 7 * 4);
    let initial_only = run(problem, &settings(10, 0, 1));
    assert_eq!(initial_only.evaluations, 10);
    assert!(!initial_only.front.is_empty());
}

#[test]
fn nsga2_treats_failed_evaluations_as_dominated() {
    // The model "fails" (NaN) for half of the box; the front must avoid it.
    let problem = Problem::Zdt1;
    let result = nsga2(
        |x| {
            if x[1] > 0.5 {
                vec![f64::NAN, f64::NAN]
            } else {
                problem.evaluate(x)
            }
        },
        &problem.bounds(),
        &settings(60, 40, 4),
    )
    .unwrap();
    assert!(!result.front.is_empty());
    for individual in &result.front {
        assert!(individual.objectives.iter().all(|f| f.is_finite()));
        assert!(individual.x[1] <= 0.5);
    }
    // Every evaluation failing still returns a population, with an empty front.
    let hopeless = nsga2(|_| vec![f64::NAN; 2], &[(0.0, 1.0)], &settings(10, 5, 1)).unwrap();
    assert_eq!(hopeless.population.len(), 10);
    assert!(hopeless.front.is_empty());
}

#[test]
fn nsga2_validates_its_inputs() {
    let f = |x: &[f64]| vec![x[0], 1.0 - x[0]];
    let ok = settings(10, 2, 1);
    assert_eq!(nsga2(f, &[], &ok).unwrap_err(), MooError::NoVariables);
    assert!(matches!(
        nsga2(f, &[(0.0, 1.0), (2.0, 1.0)], &ok),
        Err(MooError::InvalidBound { index: 1, .. })
    ));
    assert!(matches!(
        nsga2(f, &[(0.0, f64::INFINITY)], &ok),
        Err(MooError::InvalidBound { index: 0, .. })
    ));
    // A fixed parameter (lower == upper) is allowed and stays fixed.
    let fixed = nsga2(
        |x: &[f64]| vec![x[0], 1.0 - x[0] + x[1]],
        &[(0.0, 1.0), (0.3, 0.3)],
        &ok,
    )
    .unwrap();
    assert!(fixed.population.iter().all(|i| i.x[1] == 0.3));

    let bad = [
        Nsga2Settings {
            population: 1,
            ..ok.clone()
        },
        Nsga2Settings {
            pareto_fraction: 0.0,
            ..ok.clone()
        },
        Nsga2Settings {
            pareto_fraction: f64::NAN,
            ..ok.clone()
        },
        Nsga2Settings {
            crossover_probability: 1.5,
            ..ok.clone()
        },
        Nsga2Settings {
            crossover_eta: -1.0,
            ..ok.clone()
        },
        Nsga2Settings {
            mutation_eta: f64::INFINITY,
            ..ok.clone()
        },
        Nsga2Settings {
            mutation_probability: Some(-0.1),
            ..ok.clone()
        },
    ];
    for settings in &bad {
        assert!(
            matches!(
                nsga2(f, &[(0.0, 1.0)], settings),
                Err(MooError::InvalidSetting { .. })
            ),
            "{settings:?}"
        );
    }
    assert_eq!(
        nsga2(|_| Vec::new(), &[(0.0, 1.0)], &ok).unwrap_err(),
        MooError::NoObjectives
    );
    let changing = |x: &[f64]| {
        if x[0] < 0.5 {
            vec![x[0]]
        } else {
            vec![x[0], 0.0]
        }
    };
    assert!(matches!(
        nsga2(changing, &[(0.0, 1.0)], &settings(40, 5, 1)),
        Err(MooError::ObjectiveCountChanged { .. })
    ));
}

#[test]
fn settings_default_and_serde() {
    let defaults = Nsga2Settings::default();
    assert_eq!(defaults.population, 400);
    assert_eq!(defaults.generations, 100);
    assert_eq!(defaults.pareto_fraction, 0.5);
    assert_eq!(defaults.crossover_probability, 0.9);
    assert_eq!(defaults.crossover_eta, 15.0);
    assert_eq!(defaults.mutation_eta, 20.0);
    assert_eq!(defaults.mutation_probability, None);
    let parsed: Nsga2Settings = serde_json::from_str(r#"{"population": 50, "seed": 3}"#).unwrap();
    assert_eq!(parsed.population, 50);
    assert_eq!(parsed.generations, 100);
    assert!(serde_json::from_str::<Nsga2Settings>(r#"{"populaton": 50}"#).is_err());
}

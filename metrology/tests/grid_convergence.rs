//! The published worked example of the grid convergence procedure: Table 1
//! of Celik et al. 2008 (ASME J. Fluids Eng. 130, 078001, the procedure
//! `measurement-chain.md` names for u_num), three columns of a 2-D
//! backward-facing step: element counts N, so `h = N^(-1/2)`. Columns 1
//! and 2 are checked whole; column 3 (oscillatory) for its type, order and
//! e_a: the copy of the table its other numbers were typed from is not
//! certain of them.

use acq_metrology::grid_convergence::{grid_convergence, Convergence};

struct Column {
    cells: [f64; 3],
    values: [f64; 3],
    order: f64,
    /// `None` where the copy of the table these were typed from is not
    /// certain of the printed value (column 3's).
    extrapolated: Option<f64>,
    e_a_pct: f64,
    gci_fine_pct: Option<f64>,
    convergence: Convergence,
}

/// Equal to `published` within half a unit of its last printed digit.
fn agrees(ours: f64, published: f64, decimals: i32) -> bool {
    (ours - published).abs() <= 0.5 * 10f64.powi(-decimals) + 1e-12
}

#[test]
fn celik_2008_table_1_is_reproduced_to_its_printed_digits() {
    let table = [
        // The dimensionless reattachment length.
        Column {
            cells: [18_000.0, 8_000.0, 4_500.0],
            values: [6.063, 5.972, 5.863],
            order: 1.53,
            extrapolated: Some(6.1685),
            e_a_pct: 1.5,
            gci_fine_pct: Some(2.2),
            convergence: Convergence::Monotonic,
        },
        // The axial velocity at x/H = 8, y = 0.3.
        Column {
            cells: [18_000.0, 4_500.0, 980.0],
            values: [10.7880, 10.7250, 10.6050],
            order: 0.75,
            extrapolated: Some(10.8801),
            e_a_pct: 0.6,
            gci_fine_pct: Some(1.1),
            convergence: Convergence::Monotonic,
        },
        // The same velocity at y = 0.4: the values oscillate.
        Column {
            cells: [18_000.0, 4_500.0, 980.0],
            values: [6.0042, 5.9624, 6.0909],
            order: 1.5,
            extrapolated: None,
            e_a_pct: 0.7,
            gci_fine_pct: None,
            convergence: Convergence::Oscillatory,
        },
    ];
    for column in table {
        let sizes = column.cells.map(|n: f64| n.powf(-0.5));
        let study = grid_convergence(&sizes, &column.values).unwrap();
        let printed = |x: f64| {
            let text = format!("{x}");
            text.split_once('.').map_or(0, |(_, d)| d.len() as i32)
        };
        assert_eq!(study.convergence, column.convergence, "{study:?}");
        let order = study.order.unwrap();
        assert!(
            agrees(order, column.order, printed(column.order)),
            "p = {order}"
        );
        assert!(
            agrees(study.e_a_pct.unwrap(), column.e_a_pct, 1),
            "{study:?}"
        );
        let (Some(extrapolated), Some(gci)) = (column.extrapolated, column.gci_fine_pct) else {
            continue;
        };
        let ours = study.extrapolated.unwrap();
        assert!(agrees(ours, extrapolated, 4), "phi_ext = {ours}");
        let ours = study.gci_fine_pct.unwrap();
        assert!(
            agrees(ours, gci, 1),
            "GCI_fine = {ours} %, published {gci} %"
        );
        // e_ext follows from the table's own phi_ext and phi_1.
        let e_ext = 100.0 * (extrapolated - column.values[0]).abs() / extrapolated;
        let ours = study.e_ext_pct.unwrap();
        assert!(
            (ours - e_ext).abs() < 0.01,
            "e_ext = {ours} %, from the table {e_ext} %"
        );
    }
}

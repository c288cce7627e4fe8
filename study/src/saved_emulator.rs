//! An emulator of a user's model saved to a file: one Gaussian process per
//! output over the model's parameters *and* the inputs its cases set (a
//! load, a pose), fitted to the runs of an earlier study of the model. A
//! study at the rig loads it as its model, so each hold, a new case with
//! its own inputs, costs microseconds instead of a solver run.
//!
//! - **Where it is trusted.** Every column (parameter or input) keeps the
//!   range its runs covered; a run asked outside it is refused with the
//!   column named, never extrapolated: a GP far from its data returns its
//!   mean with a confident-looking number.
//! - **What it knows of its own error.** Each prediction carries the
//!   latent GP's standard deviation; the file keeps each output's
//!   leave-one-out error over its runs so a reader sees how good it is
//!   before trusting it at the rig.
//! - **Format.** JSON, `format = 1`: the columns (name, kind, lower,
//!   upper), then per output its GP as [`Gp::to_json`] writes it (a
//!   constant when every run gave the same value).

use std::path::Path;

use acq_algorithms::gp::{FixedHyperparameters, Gp, GpSettings, Kernel};
use serde::{Deserialize, Serialize};

use acq_algorithms::evaluation::Evaluation;

use super::study::{Measured, Model, ModelRun, Role, Study};

/// The file format this code writes and reads.
pub const FORMAT: u32 = 1;

/// How far past its runs' range (a share of it) a column is still
/// answered.
pub const RANGE_MARGIN: f64 = 0.02;

/// The least noise variance of a GP, relative to its outputs' variance.
pub const NOISE_FLOOR: f64 = 1e-6;

/// What a column of the emulator is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColumnKind {
    /// A parameter of the model (what a study calibrates).
    Parameter,
    /// An input a case sets (what a hold measures).
    Input,
}

/// One input of the GPs, with the range its runs covered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Column {
    pub name: String,
    pub kind: ColumnKind,
    pub lower: f64,
    pub upper: f64,
}

/// How one output is emulated.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Emulated {
    Gp(Box<Gp>),
    /// Every run gave this value.
    Constant(f64),
}

/// One output of the model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EmulatedOutput {
    pub name: String,
    pub emulated: Emulated,
    /// Runs it was fitted to.
    pub runs: usize,
    /// The root mean square of its errors at parameters it has not seen,
    /// in the output's unit (0 for a constant): each group of rows (one
    /// run of the model, all its cases) predicted by the GP of the others
    /// in [`CV_FOLDS`] folds, the hyperparameters kept. A point's own
    /// leave-one-out error would flatter it: the run's other cases, at the
    /// same parameters, stay in. A study at the rig adds it to each
    /// observation's uncertainty.
    pub error_sd: f64,
}

/// Folds of the emulator's cross-validation by run.
pub const CV_FOLDS: usize = 5;

/// One run of the model at one case: every column's value (in the
/// emulator's column order) and the outputs it gave, by name; `run`: which
/// run of the model (rows of one run share its parameters).
#[derive(Clone, Debug, PartialEq)]
pub struct EmulatorRow {
    pub run: usize,
    pub columns: Vec<f64>,
    pub outputs: Vec<(String, f64)>,
}

/// The emulator as saved.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SavedEmulator {
    pub format: u32,
    /// What it emulates, in words (the model's command).
    pub model: String,
    /// The columns its runs varied: the GPs' inputs.
    pub columns: Vec<Column>,
    /// The columns every run had at one value: a prediction must be at
    /// that value.
    pub fixed: Vec<(String, f64)>,
    pub outputs: Vec<EmulatedOutput>,
}

/// A prediction in the output's unit: the mean and the emulator's own
/// standard deviation there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmulatedValue {
    pub mean: f64,
    pub sd: f64,
}

/// Why a saved emulator cannot be read: a caller can tell a file that is
/// not there yet (run the study that saves it) from one that is damaged or
/// from another acq.
#[derive(Debug, thiserror::Error)]
pub enum EmulatorFileError {
    #[error("{}: {source}", path.display())]
    Read {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error("{}:{line}: not an emulator acq saved: {message}", path.display())]
    NotAnEmulator {
        path: std::path::PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}: an emulator of format {found}; this acq reads format {FORMAT}: save it again with this acq", path.display())]
    Format {
        path: std::path::PathBuf,
        found: u32,
    },
    /// Parses, but holds numbers no fit gives (a hand edit, a damaged file).
    #[error("{}: {message}; save it again with the study that made it", path.display())]
    Invalid {
        path: std::path::PathBuf,
        message: String,
    },
}

impl SavedEmulator {
    /// Fits one GP per output named in `rows` over `columns` (their ranges
    /// are widened to the rows' values). An output needs at least one row
    /// per column and two more.
    pub fn fit(
        model: &str,
        mut columns: Vec<Column>,
        rows: &[EmulatorRow],
        seed: u64,
    ) -> Result<SavedEmulator, String> {
        check_row_values(&columns, rows)?;
        widen_to_rows(&mut columns, rows);
        let (columns, fixed, rows) = drop_fixed_columns(columns, rows);
        let settings = emulator_gp_settings(&columns, seed);
        let outputs = output_names(&rows)
            .into_iter()
            .map(|name| fit_output(name, &rows, columns.len(), &settings))
            .collect::<Result<Vec<_>, String>>()?;
        Ok(SavedEmulator {
            format: FORMAT,
            model: model.to_string(),
            columns,
            fixed,
            outputs,
        })
    }

    /// Writes it as JSON, whole or not at all.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let text = serde_json::to_string(self).map_err(|e| e.to_string())?;
        acq_io::output::Output::write_complete(path, text.as_bytes())
            .map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Reads a saved emulator; an error names the file and, for JSON that
    /// does not parse, the line.
    pub fn load(path: &Path) -> Result<SavedEmulator, EmulatorFileError> {
        let text = acq_io::input::read_text(path).map_err(|source| EmulatorFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let emulator: SavedEmulator =
            serde_json::from_str(&text).map_err(|e| EmulatorFileError::NotAnEmulator {
                path: path.to_path_buf(),
                line: e.line(),
                message: e.to_string(),
            })?;
        if emulator.format != FORMAT {
            return Err(EmulatorFileError::Format {
                path: path.to_path_buf(),
                found: emulator.format,
            });
        }
        emulator
            .check_numbers()
            .map_err(|message| EmulatorFileError::Invalid {
                path: path.to_path_buf(),
                message,
            })?;
        Ok(emulator)
    }

    /// What a fit always gives: each column's range finite and in order,
    /// each output's cross-validated error a finite standard deviation of
    /// at least 0, a constant output finite, a GP over every column.
    fn check_numbers(&self) -> Result<(), String> {
        for column in &self.columns {
            if !(column.lower.is_finite()
                && column.upper.is_finite()
                && column.lower <= column.upper)
            {
                return Err(format!(
                    "column {}: range {} .. {} is not finite and in order",
                    column.name, column.lower, column.upper
                ));
            }
        }
        for output in &self.outputs {
            if !(output.error_sd.is_finite() && output.error_sd >= 0.0) {
                return Err(format!(
                    "output {}: error_sd = {} is not a standard deviation (finite, at least 0)",
                    output.name, output.error_sd
                ));
            }
            match &output.emulated {
                Emulated::Constant(value) if !value.is_finite() => {
                    return Err(format!(
                        "output {}: constant {value} is not finite",
                        output.name
                    ));
                }
                Emulated::Gp(gp) if gp.n_inputs() != self.columns.len() => {
                    return Err(format!(
                        "output {}: its GP takes {} input(s), the file has {} column(s); the file was edited or mixed from two emulators: save it again with the study that made it",
                        output.name,
                        gp.n_inputs(),
                        self.columns.len()
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The output `name` at the column values `values` (by name; every
    /// column needed, each within its range).
    pub fn predict(&self, values: &[(String, f64)], name: &str) -> Result<EmulatedValue, String> {
        let x = self.point(values)?;
        let output = self.output(name)?;
        Ok(match &output.emulated {
            Emulated::Constant(value) => EmulatedValue {
                mean: *value,
                sd: 0.0,
            },
            Emulated::Gp(gp) => {
                let p = gp.predict(&x);
                EmulatedValue {
                    mean: p.mean,
                    sd: p.std,
                }
            }
        })
    }

    /// The means of `names` at the column values `values`: what a sampler
    /// asks at every step (O(n d) an output, where the sd is O(n^2)).
    pub fn predict_means(
        &self,
        values: &[(String, f64)],
        names: &[&str],
    ) -> Result<Vec<f64>, String> {
        let x = self.point(values)?;
        names
            .iter()
            .map(|name| {
                Ok(match &self.output(name)?.emulated {
                    Emulated::Constant(value) => *value,
                    Emulated::Gp(gp) => gp.predict_mean(&x),
                })
            })
            .collect()
    }

    fn output(&self, name: &str) -> Result<&EmulatedOutput, String> {
        self.outputs.iter().find(|o| o.name == name).ok_or_else(|| {
            format!(
                "the emulator has no output {name:?}; it has {}",
                self.outputs
                    .iter()
                    .map(|o| o.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
    }

    /// The columns' values in order from `values`, each checked against
    /// its range.
    fn point(&self, values: &[(String, f64)]) -> Result<Vec<f64>, String> {
        for (name, at) in &self.fixed {
            if let Some((_, value)) = values.iter().find(|(n, _)| n == name) {
                if (value - at).abs() > 1e-9 * at.abs().max(1.0) {
                    return Err(format!(
                        "{name} = {value}, but every run of the emulator had {name} = {at}: it knows nothing of another value; run the model there, or vary it in the earlier study's cases"
                    ));
                }
            }
        }
        self.columns
            .iter()
            .map(|column| {
                let value = values
                    .iter()
                    .find(|(n, _)| *n == column.name)
                    .map(|(_, v)| *v)
                    .ok_or_else(|| {
                        format!(
                            "the emulator needs {} (a {} of the model)",
                            column.name,
                            match column.kind {
                                ColumnKind::Parameter => "parameter",
                                ColumnKind::Input => "case input",
                            }
                        )
                    })?;
                // A measured input a little past the runs' range (its
                // noise, at a candidate on the edge) is within reach.
                let margin = RANGE_MARGIN * (column.upper - column.lower);
                if !(column.lower - margin..=column.upper + margin).contains(&value) {
                    return Err(format!(
                        "{} = {value} is outside the range the emulator's runs covered ({} to {}): it does not extrapolate; run the model there, or widen the earlier study's cases",
                        column.name, column.lower, column.upper
                    ));
                }
                Ok(value)
            })
            .collect()
    }
}

/// An error when a row has another number of column values than the
/// emulator has columns, or a value that is not finite.
fn check_row_values(columns: &[Column], rows: &[EmulatorRow]) -> Result<(), String> {
    if let Some(row) = rows.iter().find(|r| r.columns.len() != columns.len()) {
        return Err(format!(
            "a run has {} column values, the emulator {} columns",
            row.columns.len(),
            columns.len()
        ));
    }
    if let Some((k, _)) = rows
        .iter()
        .flat_map(|r| r.columns.iter().enumerate())
        .find(|(_, v)| !v.is_finite())
    {
        return Err(format!("a run has no finite value of {}", columns[k].name));
    }
    Ok(())
}

/// Widens each column's range to the values the rows have of it.
fn widen_to_rows(columns: &mut [Column], rows: &[EmulatorRow]) {
    for (k, column) in columns.iter_mut().enumerate() {
        for row in rows {
            column.lower = column.lower.min(row.columns[k]);
            column.upper = column.upper.max(row.columns[k]);
        }
    }
}

/// Takes out the columns every run had at one value (no input of a GP):
/// the varied columns, the fixed ones with their value, and the rows with
/// the varied columns' values only.
fn drop_fixed_columns(
    columns: Vec<Column>,
    rows: &[EmulatorRow],
) -> (Vec<Column>, Vec<(String, f64)>, Vec<EmulatorRow>) {
    let varied: Vec<bool> = columns.iter().map(|c| c.upper > c.lower).collect();
    let fixed: Vec<(String, f64)> = columns
        .iter()
        .zip(&varied)
        .filter(|(c, &v)| !v && c.lower.is_finite())
        .map(|(c, _)| (c.name.clone(), c.lower))
        .collect();
    let columns: Vec<Column> = columns
        .into_iter()
        .zip(&varied)
        .filter(|(_, &v)| v)
        .map(|(c, _)| c)
        .collect();
    let rows: Vec<EmulatorRow> = rows
        .iter()
        .map(|row| EmulatorRow {
            run: row.run,
            columns: row
                .columns
                .iter()
                .zip(&varied)
                .filter(|(_, &v)| v)
                .map(|(x, _)| *x)
                .collect(),
            outputs: row.outputs.clone(),
        })
        .collect();
    (columns, fixed, rows)
}

/// The outputs the rows name, in first-seen order.
fn output_names(rows: &[EmulatorRow]) -> Vec<&str> {
    let mut names: Vec<&str> = Vec::new();
    for row in rows {
        for (name, _) in &row.outputs {
            if !names.contains(&name.as_str()) {
                names.push(name);
            }
        }
    }
    names
}

/// The GP settings of every output: Matérn 5/2 with ARD over the columns'
/// ranges, seeded, with a floor on the noise.
fn emulator_gp_settings(columns: &[Column], seed: u64) -> GpSettings {
    GpSettings {
        kernel: Kernel::Matern52,
        ard: true,
        restarts: 3,
        seed,
        input_bounds: Some(columns.iter().map(|c| (c.lower, c.upper)).collect()),
        // A floor on the noise (a thousandth of the outputs' spread, as
        // an sd): on a deterministic model's runs the likelihood
        // otherwise drives the noise to nothing and the signal to its
        // bound, an interpolant too ill-conditioned to trust between
        // its runs (seen on a smooth three-column model: off by a
        // fifth of its range one unit from a run).
        noise_bounds: (NOISE_FLOOR, 1.0),
        ..GpSettings::default()
    }
}

/// One output emulated from the rows that gave it a finite value: a
/// constant when they all gave the same, else a GP with its error by run;
/// an error when fewer rows than the columns and two more gave it.
fn fit_output(
    name: &str,
    rows: &[EmulatorRow],
    column_count: usize,
    settings: &GpSettings,
) -> Result<EmulatedOutput, String> {
    let mut runs: Vec<usize> = Vec::new();
    let (xs, ys): (Vec<Vec<f64>>, Vec<f64>) = rows
        .iter()
        .filter_map(|row| {
            let y = row.outputs.iter().find(|(n, _)| n == name)?.1;
            y.is_finite().then(|| {
                runs.push(row.run);
                (row.columns.clone(), y)
            })
        })
        .unzip();
    if xs.len() < column_count + 2 {
        return Err(format!(
            "output {name}: {} runs gave it, the emulator needs at least {} (one per column and two more)",
            xs.len(),
            column_count + 2
        ));
    }
    let first = ys[0];
    if ys.iter().all(|&y| y == first) {
        return Ok(EmulatedOutput {
            name: name.to_string(),
            emulated: Emulated::Constant(first),
            runs: ys.len(),
            error_sd: 0.0,
        });
    }
    let gp = Gp::fit(&xs, &ys, settings)
        .map_err(|e| format!("output {name}: the GP does not fit its runs: {e}"))?;
    let error_sd = error_by_run(&gp, &xs, &ys, &runs);
    Ok(EmulatedOutput {
        name: name.to_string(),
        emulated: Emulated::Gp(Box::new(gp)),
        runs: ys.len(),
        error_sd,
    })
}

/// The root mean square error of `gp`'s hyperparameters at runs left out:
/// the runs split into [`CV_FOLDS`] folds, each fold's rows predicted by a
/// GP of the other folds' rows (their mean taken out, the hyperparameters
/// fixed); the leave-one-out error when there are too few runs to fold.
fn error_by_run(gp: &Gp, xs: &[Vec<f64>], ys: &[f64], runs: &[usize]) -> f64 {
    let mut distinct: Vec<usize> = runs.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < CV_FOLDS {
        return gp.leave_one_out().rmse;
    }
    let fold_of = |run: usize| distinct.binary_search(&run).unwrap_or(0) % CV_FOLDS;
    let hyper = gp.hyperparameters();
    let mut squares = 0.0;
    let mut count = 0usize;
    for fold in 0..CV_FOLDS {
        let (train, test): (Vec<usize>, Vec<usize>) =
            (0..ys.len()).partition(|&i| fold_of(runs[i]) != fold);
        if train.is_empty() || test.is_empty() {
            continue;
        }
        let mean = train.iter().map(|&i| ys[i]).sum::<f64>() / train.len() as f64;
        let settings = GpSettings {
            kernel: gp.kernel(),
            fixed: Some(FixedHyperparameters {
                length_scales: hyper.length_scales.clone(),
                signal_variance: hyper.signal_variance,
                noise_variance: hyper.noise_variance,
            }),
            ..GpSettings::default()
        };
        let inputs: Vec<Vec<f64>> = train.iter().map(|&i| xs[i].clone()).collect();
        let outputs: Vec<f64> = train.iter().map(|&i| ys[i] - mean).collect();
        let Ok(fold_gp) = Gp::fit(&inputs, &outputs, &settings) else {
            return f64::INFINITY;
        };
        for &i in &test {
            squares += (fold_gp.predict_mean(&xs[i]) + mean - ys[i]).powi(2);
            count += 1;
        }
    }
    (squares / count.max(1) as f64).sqrt()
}

/// The rows a study's logged runs give: for each successful run and each
/// fit case, the model's inputs there (parameters and the case's inputs,
/// by the model's names) and the scalar outputs observed in the case; with
/// the columns (parameters first as the study lists them, then the cases'
/// inputs in first-seen order).
pub fn rows_of_study(study: &Study, evaluations: &[Evaluation]) -> (Vec<Column>, Vec<EmulatorRow>) {
    let parameter_inputs: Vec<&str> = study.parameters.iter().map(|p| p.input.as_str()).collect();
    let mut names: Vec<String> = Vec::new();
    // (run, the model's inputs, the observed outputs), by name.
    type Named = Vec<(String, f64)>;
    let mut rows: Vec<(usize, Named, Named)> = Vec::new();
    for (run, evaluation) in evaluations.iter().enumerate() {
        let Ok(outputs) = &evaluation.outcome else {
            continue;
        };
        let mut offset = 0;
        for (index, case) in study.cases_with(Role::Fit) {
            if case.priors {
                offset += case.observations.len();
                continue;
            }
            let inputs = study.inputs_of(index, &evaluation.parameters);
            let mut observed = Vec::new();
            for observation in &case.observations {
                if let (Measured::Scalar { .. }, Some(&value)) =
                    (&observation.measured, outputs.get(offset))
                {
                    observed.push((observation.output.clone(), value));
                }
                offset += 1;
            }
            for (name, _) in &inputs {
                if !names.contains(name) {
                    names.push(name.clone());
                }
            }
            rows.push((run, inputs, observed));
        }
    }
    // Parameters first, in the study's order, then the cases' inputs.
    names.sort_by_key(|n| {
        parameter_inputs
            .iter()
            .position(|p| p == n)
            .unwrap_or(usize::MAX)
    });
    // A parameter's column spans its search bounds (the start design
    // spread the runs over them); an input's, the cases' values.
    let columns = names
        .iter()
        .map(
            |name| match study.parameters.iter().find(|p| &p.input == name) {
                Some(p) => Column {
                    name: name.clone(),
                    kind: ColumnKind::Parameter,
                    lower: p.search.lower,
                    upper: p.search.upper,
                },
                None => Column {
                    name: name.clone(),
                    kind: ColumnKind::Input,
                    lower: f64::INFINITY,
                    upper: f64::NEG_INFINITY,
                },
            },
        )
        .collect();
    let rows = rows
        .into_iter()
        .filter_map(|(run, inputs, outputs)| {
            let columns = names
                .iter()
                .map(|name| inputs.iter().find(|(n, _)| n == name).map(|(_, v)| *v))
                .collect::<Option<Vec<f64>>>()?;
            Some(EmulatorRow {
                run,
                columns,
                outputs,
            })
        })
        .collect();
    (columns, rows)
}

/// A saved emulator as a study's model: cheap, scalars only.
pub struct EmulatedModel {
    pub emulator: SavedEmulator,
}

impl Model for EmulatedModel {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
        if let Some(curve) = curves.first() {
            return Err(format!("an emulator gives numbers, not curves ({curve:?})"));
        }
        let scalars = self.emulator.predict_means(inputs, scalars)?;
        Ok(ModelRun {
            scalars,
            curves: Vec::new(),
        })
    }

    fn is_cheap(&self) -> bool {
        true
    }

    fn own_error_sd(&self, inputs: &[(String, f64)], scalars: &[&str]) -> Option<Vec<f64>> {
        scalars
            .iter()
            .map(|name| self.emulator.predict(inputs, name).ok().map(|v| v.sd))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth model of two parameters and one case input.
    fn model(stiffness: f64, mass: f64, load: f64) -> f64 {
        load / stiffness + 0.3 * mass * (1.0 + 0.2 * load).ln()
    }

    fn columns() -> Vec<Column> {
        [
            ("stiffness", ColumnKind::Parameter),
            ("mass", ColumnKind::Parameter),
            ("load", ColumnKind::Input),
        ]
        .iter()
        .map(|&(name, kind)| Column {
            name: name.into(),
            kind,
            lower: f64::INFINITY,
            upper: f64::NEG_INFINITY,
        })
        .collect()
    }

    /// 120 runs spread over the three columns (a Halton sequence), as an
    /// earlier study whose cases spread the load over the rig's range
    /// would give.
    fn rows() -> Vec<EmulatorRow> {
        let halton = |mut k: usize, base: usize| {
            let (mut x, mut f) = (0.0, 1.0);
            while k > 0 {
                f /= base as f64;
                x += f * (k % base) as f64;
                k /= base;
            }
            x
        };
        (1..=120)
            .map(|k| {
                let (s, m, l) = (
                    1.0 + 2.0 * halton(k, 2),
                    10.0 + 20.0 * halton(k, 3),
                    30.0 * halton(k, 5),
                );
                EmulatorRow {
                    run: k,
                    columns: vec![s, m, l],
                    outputs: vec![
                        ("deflection_mm".into(), model(s, m, l)),
                        ("unit".into(), 1.0),
                    ],
                }
            })
            .collect()
    }

    fn at(s: f64, m: f64, l: f64) -> Vec<(String, f64)> {
        vec![
            ("stiffness".into(), s),
            ("mass".into(), m),
            ("load".into(), l),
        ]
    }

    /// Between its runs it reproduces the model within a few of its own
    /// standard deviations, and a saved emulator predicts the same after
    /// loading.
    #[test]
    fn it_reproduces_the_model_between_its_runs_and_survives_a_round_trip() {
        let emulator = SavedEmulator::fit("a smooth model", columns(), &rows(), 1).unwrap();
        assert!(
            emulator.columns[2].upper > 29.0,
            "the range its runs covered"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("emulator.json");
        emulator.save(&path).unwrap();
        let loaded = SavedEmulator::load(&path).unwrap();
        let range = model(1.0, 30.0, 30.0) - model(3.0, 10.0, 0.0);
        // Its own account of its error at runs it has not seen: under a
        // hundredth of the outputs' range, as the checks below find it.
        assert!(
            emulator.outputs[0].error_sd < 0.01 * range,
            "{:?}",
            emulator.outputs[0]
        );
        for (s, m, l) in [(1.3, 12.0, 5.0), (2.2, 27.0, 17.0), (2.9, 19.0, 29.0)] {
            let p = emulator.predict(&at(s, m, l), "deflection_mm").unwrap();
            let truth = model(s, m, l);
            assert!(
                (p.mean - truth).abs() < 0.01 * range.abs(),
                "at {s}, {m}, {l}: {} against {truth}",
                p.mean
            );
            assert!(
                (p.mean - truth).abs() < 5.0 * p.sd + 1e-9,
                "{p:?} against {truth}"
            );
            assert_eq!(loaded.predict(&at(s, m, l), "deflection_mm").unwrap(), p);
        }
        assert_eq!(
            emulator.predict(&at(2.0, 20.0, 10.0), "unit").unwrap(),
            EmulatedValue { mean: 1.0, sd: 0.0 }
        );
    }

    /// Outside its runs, without a column, or for an output it lacks, it
    /// says so; a file of another format is refused.
    #[test]
    fn it_refuses_what_it_cannot_answer() {
        let emulator = SavedEmulator::fit("a smooth model", columns(), &rows(), 1).unwrap();
        let outside = emulator
            .predict(&at(2.0, 20.0, 45.0), "deflection_mm")
            .unwrap_err();
        assert!(
            outside.contains("load = 45") && outside.contains("extrapolate"),
            "{outside}"
        );
        let missing = emulator
            .predict(&at(2.0, 20.0, 10.0)[..2], "deflection_mm")
            .unwrap_err();
        assert!(missing.contains("needs load"), "{missing}");
        let unknown = emulator
            .predict(&at(2.0, 20.0, 10.0), "stress")
            .unwrap_err();
        assert!(unknown.contains("deflection_mm"), "{unknown}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("emulator.json");
        let mut other = emulator.clone();
        other.format = 7;
        other.save(&path).unwrap();
        let other = SavedEmulator::load(&path).unwrap_err();
        assert!(
            matches!(other, EmulatorFileError::Format { found: 7, .. })
                && other.to_string().contains("format 7"),
            "{other}"
        );
        std::fs::write(&path, "{\n  \"format\": 1,\n  oops").unwrap();
        let bad = SavedEmulator::load(&path).unwrap_err();
        assert!(
            matches!(bad, EmulatorFileError::NotAnEmulator { line: 3, .. })
                && bad.to_string().contains("emulator.json:3"),
            "{bad}"
        );
        // A hand-edited error that is no standard deviation.
        let mut edited = emulator.clone();
        edited.outputs[0].error_sd = -0.5;
        edited.save(&path).unwrap();
        let invalid = SavedEmulator::load(&path).unwrap_err();
        assert!(
            matches!(invalid, EmulatorFileError::Invalid { .. })
                && invalid.to_string().contains("error_sd = -0.5"),
            "{invalid}"
        );
        // A column taken away: its GPs still take every column.
        let mut narrower = emulator.clone();
        narrower.columns.pop();
        narrower.save(&path).unwrap();
        let wrong = SavedEmulator::load(&path).unwrap_err();
        let said = format!(
            "its GP takes {} input(s), the file has {} column(s)",
            emulator.columns.len(),
            emulator.columns.len() - 1
        );
        assert!(wrong.to_string().contains(&said), "{wrong}");
        let missing = SavedEmulator::load(&path.with_file_name("none.json")).unwrap_err();
        assert!(
            matches!(missing, EmulatorFileError::Read { .. }),
            "{missing}"
        );
        let spread: Vec<EmulatorRow> = rows().into_iter().step_by(23).take(4).collect();
        let few = SavedEmulator::fit("a smooth model", columns(), &spread, 1).unwrap_err();
        assert!(few.contains("at least 5"), "{few}");
    }
}

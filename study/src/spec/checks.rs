//! One check per section of a spec, each before anything runs or any run
//! directory exists; each problem says where (the file, or the line of
//! the `[[table]]` at fault) and what to give instead.

use std::path::Path;

use acq_algorithms::bo::Acquisition;
use acq_algorithms::gp::Kernel;

use super::model::{BuiltinModels, CommandSpec, KeyReader, ModelKind};
use super::problem::SpecProblem;
use super::schema::{
    ExecutorKind, ExecutorSpec, MethodName, ModelName, Search, SpecFile, MAX_CHAINS, MAX_DRAWS,
    MAX_EVALUATIONS, MAX_PARALLEL, MAX_PREDICTIVE_RUNS, MAX_REFINEMENT_RUNS, MAX_RETRIES,
    MAX_TIMEOUT_S, START_DESIGNS,
};
use crate::study::Role;
use crate::surrogate_moo::Pick;

/// `model` and the keys that belong to it: a command, a model the caller
/// brings, or a built-in model, which `builtins` resolves.
pub fn model(
    file: &SpecFile,
    given: bool,
    builtins: &dyn BuiltinModels,
) -> Result<ModelKind, SpecProblem> {
    let problem = |message: &str| Err(SpecProblem::file(message));
    let reader = match file.model {
        ModelName::Command if given => KeyReader::Given,
        ModelName::Command => KeyReader::Command,
        name => KeyReader::Builtin(name),
    };
    if let Some(message) = builtins.misplaced_key(file, reader) {
        return problem(&message);
    }
    match file.model {
        // The caller's model takes the command's place: one spec serves
        // both, so the two can be compared run for run.
        ModelName::Command if given => Ok(ModelKind::Given),
        ModelName::Command if file.command.is_empty() => {
            problem("command is empty; give the program and its arguments")
        }
        ModelName::Command => Ok(ModelKind::Command(CommandSpec {
            command: file.command.clone(),
            output_file: file.output_file.clone(),
            link_files: file.link_files.clone(),
            copy_files: file.copy_files.clone(),
            timeout_s: file.timeout_s,
            retries: file.retries,
            curves: file.curves.clone(),
        })),
        name if given => problem(&format!(
            "model = \"{0}\" runs the built-in twin: leave out the model given to the study, or model = \"{0}\"",
            name.name()
        )),
        name if !file.command.is_empty() => problem(&format!(
            "model = \"{}\" runs the built-in twin; leave out command",
            name.name()
        )),
        name => builtins
            .resolve(name, file)
            .map(ModelKind::Builtin)
            .map_err(SpecProblem::file),
    }
}

/// `[emulator]` in a study of cases: `save` only, of a user's model whose
/// cases set inputs for the emulator to span.
pub fn emulator(file: &SpecFile) -> Result<(), SpecProblem> {
    let Some(emulator) = &file.emulator else {
        return Ok(());
    };
    let problem = |message: &str| Err(SpecProblem::file(message));
    if emulator.load.is_some() {
        return problem("[emulator] load belongs to a study at the rig ([holds]); a study of cases runs its model");
    }
    match &emulator.save {
        None => problem("[emulator]: give save = \"emulator.json\", the file to leave in the run directory"),
        Some(_) if file.model != ModelName::Command => problem(
            "[emulator] save emulates a user's solver (command); the built-in twins run at the rig themselves",
        ),
        Some(name) if name.is_empty() || name.contains(['/', '\\']) => problem(
            "[emulator] save is a file name in the run directory (emulator.json), not a path",
        ),
        Some(_) if file.cases.is_empty() => problem(
            "[emulator] save needs [[case]]s that set the inputs the rig will measure: the emulator spans the parameters and the cases' inputs",
        ),
        Some(_) => Ok(()),
    }
}

/// The observations are given one way: `[[output]]`s and `[[curve]]`s
/// without cases, or each case's `measured` table; each name once.
pub fn observations_given(file: &SpecFile) -> Result<(), SpecProblem> {
    if file.cases.is_empty() && file.outputs.is_empty() && file.holds.is_some() {
        return Err(SpecProblem::file(
            "a study at the rig ([holds]) takes its cases from a recording's holds: run it with `acq record --study` or `acq view SESSION_DIR --study`",
        ));
    }
    if file.cases.is_empty() && file.outputs.is_empty() && file.curves.is_empty() {
        return Err(SpecProblem::file(
            "no [[output]] with a measured value, no [[curve]] to compare and no [[case]]",
        ));
    }
    if !file.cases.is_empty() && !file.outputs.is_empty() {
        return Err(SpecProblem::table(
            "[[output]]",
            0,
            "with [[case]], give each case's measured values in its `measured` table instead of [[output]]",
        ));
    }
    let mut names: Vec<&str> = file.outputs.iter().map(|o| o.name.as_str()).collect();
    names.extend(file.curves.iter().map(|c| c.name.as_str()));
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(SpecProblem::file(format!(
                "the output or curve name {name:?} is given twice"
            )));
        }
    }
    Ok(())
}

/// `timeout_s` and `retries`.
pub fn runs(file: &SpecFile) -> Result<(), SpecProblem> {
    if !(file.timeout_s.is_finite() && file.timeout_s > 0.0 && file.timeout_s <= MAX_TIMEOUT_S) {
        return Err(SpecProblem::file(format!(
            "timeout_s = {}: give seconds above 0 and at most {MAX_TIMEOUT_S} (116 days)",
            file.timeout_s
        )));
    }
    if file.retries > MAX_RETRIES {
        return Err(SpecProblem::file(format!(
            "retries = {}: at most {MAX_RETRIES}",
            file.retries
        )));
    }
    Ok(())
}

/// `[executor]` (and the top-level `parallel`): the runs at once.
pub fn executor(file: &SpecFile) -> Result<usize, SpecProblem> {
    let here = |message: String| SpecProblem::table("[executor]", 0, message);
    let executor = &file.executor;
    let parallel = executor_section(executor, file.parallel).map_err(here)?;
    if file.model != ModelName::Command && executor.kind == ExecutorKind::Slurm {
        return Err(here(
            "the built-in twins (model = \"excavator\", \"gtn\") run inside acq; a Slurm executor is for a command".into(),
        ));
    }
    Ok(parallel)
}

fn executor_section(executor: &ExecutorSpec, top_parallel: Option<usize>) -> Result<usize, String> {
    let slurm_only = [
        ("partition", executor.partition.is_some()),
        ("account", executor.account.is_some()),
        ("time_limit", executor.time_limit.is_some()),
        ("cpus_per_job", executor.cpus_per_job.is_some()),
        ("memory_per_job", executor.memory_per_job.is_some()),
        ("sbatch_args", !executor.sbatch_args.is_empty()),
        ("prelude", !executor.prelude.is_empty()),
    ];
    if executor.kind != ExecutorKind::Slurm {
        if let Some((name, _)) = slurm_only.iter().find(|(_, given)| *given) {
            return Err(format!(
                "[executor] {name} is a Slurm option; add kind = \"slurm\" or leave it out"
            ));
        }
    }
    if let Some(limit) = &executor.time_limit {
        if !is_slurm_time(limit) {
            return Err(format!(
                "[executor] time_limit = {limit:?}: give one of Slurm's formats: minutes (\"30\"), \"MM:SS\", \"HH:MM:SS\", \"D-HH\", \"D-HH:MM\" or \"D-HH:MM:SS\" (minutes and seconds below 60, hours after a day below 24), or \"UNLIMITED\""
            ));
        }
    }
    if let Some(memory) = &executor.memory_per_job {
        if !is_slurm_memory(memory) {
            return Err(format!(
                "[executor] memory_per_job = {memory:?}: give Slurm's --mem size, a whole number with an optional unit K, M, G or T (\"8G\", \"512M\"; no unit is megabytes)"
            ));
        }
    }
    if executor.cpus_per_job == Some(0) {
        return Err("[executor] cpus_per_job = 0: give at least 1".into());
    }
    let parallel = match (top_parallel, executor.parallel) {
        (Some(top), Some(own)) if top != own => {
            return Err(format!(
                "parallel = {top} and [executor] parallel = {own}: give it once, under [executor]"
            ))
        }
        (top, own) => own.or(top).unwrap_or(1),
    };
    if !(1..=MAX_PARALLEL).contains(&parallel) {
        return Err(format!(
            "parallel = {parallel}: give 1 to {MAX_PARALLEL} runs at a time"
        ));
    }
    Ok(parallel)
}

/// A memory size as `sbatch --mem` takes it: digits, then optionally one
/// of K, M, G, T (either case).
pub fn is_slurm_memory(text: &str) -> bool {
    let digits = text.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    text.len() - digits.len() <= 1
        && !digits.is_empty()
        && digits.len() <= 12
        && digits.bytes().all(|b| b.is_ascii_digit())
}

/// A time in one of Slurm's formats (`sbatch --time`): minutes, MM:SS,
/// HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS, or UNLIMITED / INFINITE. Checked
/// here, so a malformed one is refused before any run directory exists
/// rather than by `sbatch` for every job.
pub fn is_slurm_time(text: &str) -> bool {
    // Slurm's own words for no limit, in any case, and its -1.
    if text == "-1" || matches!(text.to_ascii_uppercase().as_str(), "UNLIMITED" | "INFINITE") {
        return true;
    }
    let number = |part: &str, below: Option<u64>| {
        !part.is_empty()
            && part.len() <= 9
            && part.bytes().all(|b| b.is_ascii_digit())
            && below.is_none_or(|limit| part.parse::<u64>().is_ok_and(|v| v < limit))
    };
    match text.split_once('-') {
        Some((days, clock)) => {
            let parts: Vec<&str> = clock.split(':').collect();
            number(days, None)
                && (1..=3).contains(&parts.len())
                && number(parts[0], Some(24))
                && parts[1..].iter().all(|p| number(p, Some(60)))
        }
        None => {
            let parts: Vec<&str> = text.split(':').collect();
            (1..=3).contains(&parts.len())
                && number(parts[0], None)
                && parts[1..].iter().all(|p| number(p, Some(60)))
        }
    }
}

/// The files a run reads and writes: each inside its run directory, and
/// those staged from next to the spec there.
pub fn files(file: &SpecFile, spec_directory: &Path) -> Result<(), SpecProblem> {
    let problem = |e: acq_error::AcqError| SpecProblem::file(e.to_string());
    let any_run = Path::new("runs/000001");
    if !file.output_file.is_empty() {
        acq_io::output::inside(any_run, &file.output_file, "output_file").map_err(problem)?;
    }
    for curve in &file.curves {
        acq_io::output::inside(any_run, &curve.file, "curve.file").map_err(problem)?;
    }
    for (what, files) in [
        ("link_files", &file.link_files),
        ("copy_files", &file.copy_files),
    ] {
        for name in files {
            acq_io::output::inside(any_run, name, what).map_err(problem)?;
            let source = spec_directory.join(name);
            if !source.exists() {
                return Err(SpecProblem::file(format!(
                    "{what}: {} does not exist (paths are relative to the spec)",
                    source.display()
                )));
            }
            acq_io::input::note_input(&source);
        }
    }
    Ok(())
}

/// `[posterior]`: its counts within reach.
pub fn posterior(file: &SpecFile) -> Result<(), SpecProblem> {
    let Some(posterior) = &file.posterior else {
        return Ok(());
    };
    if !(100..=MAX_DRAWS).contains(&posterior.draws) {
        return Err(SpecProblem::file(format!(
            "posterior.draws = {}: give 100 to {MAX_DRAWS} draws per chain (R-hat and ESS need a hundred at least)",
            posterior.draws
        )));
    }
    if !(1..=MAX_CHAINS).contains(&posterior.chains) {
        return Err(SpecProblem::file(format!(
            "posterior.chains = {}: give 1 to {MAX_CHAINS} chains (4 lets R-hat tell whether they agree)",
            posterior.chains
        )));
    }
    if posterior.predictive_runs > MAX_PREDICTIVE_RUNS {
        return Err(SpecProblem::file(format!(
            "posterior.predictive_runs = {}: at most {MAX_PREDICTIVE_RUNS}",
            posterior.predictive_runs
        )));
    }
    if posterior.refinement_runs > MAX_REFINEMENT_RUNS {
        return Err(SpecProblem::file(format!(
            "posterior.refinement_runs = {}: at most {MAX_REFINEMENT_RUNS} (each is a model run; 0 samples on the search's runs alone)",
            posterior.refinement_runs
        )));
    }
    let validated: Vec<&String> = file
        .cases
        .iter()
        .filter(|c| c.role == Role::Validate)
        .flat_map(|c| c.measured.keys())
        .collect();
    for (name, u) in &posterior.numerical_uncertainty {
        if !validated.contains(&name) {
            return Err(SpecProblem::file(format!(
                "posterior.numerical_uncertainty.{name:?}: no validate case measures it; name one of {}",
                if validated.is_empty() {
                    "the validate cases' measured values (there are none)".to_string()
                } else {
                    validated.iter().map(|n| format!("{n:?}")).collect::<Vec<_>>().join(", ")
                }
            )));
        }
        if !(u.is_finite() && *u >= 0.0) {
            return Err(SpecProblem::file(format!(
                "posterior.numerical_uncertainty.{name:?} = {u}: give the solver's numerical uncertainty as a number of at least 0, in the value's unit (from a mesh study: the grid convergence index, say)"
            )));
        }
    }
    Ok(())
}

/// `[search]`: the start design, the budgets and the named settings.
pub fn search(search: &Search) -> Result<(), SpecProblem> {
    search_section(search).map_err(SpecProblem::file)
}

fn search_section(search: &Search) -> Result<(), String> {
    if !START_DESIGNS.contains(&search.start.as_str()) && !search.start.ends_with(".csv") {
        return Err(format!(
            "search.start = {:?}: use one of {}, or a CSV file of points (name ending in .csv, next to the spec)",
            search.start,
            START_DESIGNS.join(", ")
        ));
    }
    if !(3..=MAX_EVALUATIONS).contains(&search.max_evals)
        || !(2..=MAX_EVALUATIONS).contains(&search.start_runs)
    {
        return Err(format!(
            "search: give max_evals from 3 and start_runs from 2, each at most {MAX_EVALUATIONS} (got {} and {})",
            search.max_evals, search.start_runs
        ));
    }
    if let Some(text) = &search.acquisition {
        text.parse::<Acquisition>()
            .map_err(|e| format!("search.acquisition = {text:?}: {e}"))?;
    }
    if let Some(text) = &search.kernel {
        text.parse::<Kernel>()
            .map_err(|e| format!("search.kernel = {text:?}: {e}"))?;
    }
    if let Some(text) = &search.pick {
        text.parse::<Pick>()
            .map_err(|e| format!("search.pick: {e}"))?;
    }
    let counts = [
        ("training_runs", search.training_runs, 3),
        ("test_runs", search.test_runs, 0),
        ("population", search.population, 4),
        ("generations", search.generations, 0),
        ("refine_rounds", search.refine_rounds, 0),
        ("patience", search.patience, 1),
    ];
    for (name, value, least) in counts {
        if let Some(value) = value {
            if !(least..=MAX_EVALUATIONS).contains(&value) {
                return Err(format!(
                    "search.{name} = {value}: give {least} to {MAX_EVALUATIONS}"
                ));
            }
        }
    }
    if let Some(f) = search.pareto_fraction {
        if !(f > 0.0 && f <= 1.0) {
            return Err(format!(
                "search.pareto_fraction = {f}: give a number in (0, 1]"
            ));
        }
    }
    for (name, value) in [
        ("refine_tolerance", search.refine_tolerance),
        ("target_loss_pct", search.target_loss_pct),
    ] {
        if let Some(t) = value {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("search.{name} = {t}: give a number >= 0"));
            }
        }
    }
    Ok(())
}

/// `[search] method = "multi-fidelity"`: a `[mesh_study]` (the command's
/// `{mesh}`) and a cheap size coarser than its `calibrate_at`; its own
/// settings only with that method.
pub fn multi_fidelity(
    search: &Search,
    mesh_study: Option<&crate::mesh_study::MeshStudySettings>,
) -> Result<(), SpecProblem> {
    let problem = |message: String| Err(SpecProblem::file(format!("search: {message}")));
    if search.method != MethodName::MultiFidelity {
        if search.cheap_mesh.is_some()
            || search.max_expensive.is_some()
            || search.expensive_start_runs.is_some()
        {
            return problem(
                "cheap_mesh, max_expensive and expensive_start_runs belong to method = \"multi-fidelity\": set it, or remove them".into(),
            );
        }
        return Ok(());
    }
    let Some(mesh_study) = mesh_study else {
        return problem(
            "method = \"multi-fidelity\" runs the model at two element sizes through {mesh}: add [mesh_study] (its calibrate_at is the expensive level) and {mesh} to the command".into(),
        );
    };
    let fine = mesh_study.calibrate_at;
    match search.cheap_mesh {
        None => problem(format!(
            "method = \"multi-fidelity\" needs cheap_mesh, the coarse element size of the cheap runs (larger than [mesh_study] calibrate_at = {fine})"
        )),
        Some(cheap) if !(cheap.is_finite() && cheap > fine) => problem(format!(
            "cheap_mesh = {cheap}: give an element size larger (coarser) than [mesh_study] calibrate_at = {fine}, the expensive level"
        )),
        Some(_) => {
            let start = search.start_runs;
            let expensive_start = search.expensive_start_runs();
            let max_expensive = search.max_expensive.unwrap_or(search.max_evals);
            if !(2..=start).contains(&expensive_start) {
                return problem(format!(
                    "expensive_start_runs = {expensive_start}: give 2 to start_runs ({start}); co-kriging needs two expensive runs"
                ));
            }
            if max_expensive <= expensive_start || search.max_evals <= start + expensive_start {
                return problem(format!(
                    "max_expensive ({max_expensive}) and max_evals ({}) leave no run after the start designs ({start} cheap, {expensive_start} expensive): raise them",
                    search.max_evals
                ));
            }
            Ok(())
        }
    }
}

/// The most element sizes a `[mesh_study]` runs: a run each.
pub const MAX_MESH_SIZES: usize = 20;

/// `[mesh_study]`: at least three distinct positive sizes, `at` naming
/// parameters within their ranges, and `{mesh}` where the sizes go; a
/// command that takes `{mesh}` needs the section.
pub fn mesh_study(
    file: &SpecFile,
    model: &ModelKind,
) -> Result<Option<crate::mesh_study::MeshStudySettings>, SpecProblem> {
    use crate::mesh_study::{MeshStudySettings, MESH_INPUT};
    let placeholder = format!("{{{MESH_INPUT}}}");
    let takes_mesh = file.command.iter().any(|a| a.contains(&placeholder));
    let Some(section) = &file.mesh_study else {
        if takes_mesh && matches!(model, ModelKind::Command(_)) {
            return Err(SpecProblem::file(format!(
                "the command takes {placeholder}, but the spec has no [mesh_study]: add [mesh_study] with sizes = [...] (the element sizes; a calibration runs at the smallest)"
            )));
        }
        return Ok(None);
    };
    let problem = |message: String| SpecProblem::file(format!("[mesh_study] {message}"));
    match model {
        ModelKind::Command(_) if !takes_mesh => {
            return Err(problem(format!(
                "needs {placeholder} in the command: the element size each run takes"
            )))
        }
        // The excavator twin takes the size as its frames' element length.
        _ => {}
    }
    let sizes = &section.sizes;
    if sizes.len() < 3 {
        return Err(problem(format!(
            "sizes = {sizes:?}: give at least three element sizes (Celik et al. 2008 needs three; more are fitted by least squares)"
        )));
    }
    if sizes.len() > MAX_MESH_SIZES {
        return Err(problem(format!(
            "{} sizes: give at most {MAX_MESH_SIZES} (a run each; the order and the extrapolation are fitted from three or more, and more sizes than this add runs, not certainty)",
            sizes.len()
        )));
    }
    if let Some(bad) = sizes.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        return Err(problem(format!(
            "sizes: {bad} is not a positive element size"
        )));
    }
    let mut sorted = sizes.clone();
    sorted.sort_by(f64::total_cmp);
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return Err(problem(format!("sizes = {sizes:?}: each size once")));
    }
    if file.parameters.iter().any(|p| p.name == MESH_INPUT)
        || file.cases.iter().any(|c| c.inputs.contains_key(MESH_INPUT))
    {
        return Err(problem(format!(
            "the name {MESH_INPUT:?} is the element size's: rename the parameter or case input that has it"
        )));
    }
    for (name, value) in &section.at {
        let Some(parameter) = file.parameters.iter().find(|p| p.name == *name) else {
            return Err(problem(format!(
                "at.{name}: no parameter has this name; name one of {}",
                file.parameters
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        if !(value.is_finite() && (parameter.lower..=parameter.upper).contains(value)) {
            return Err(problem(format!(
                "at.{name} = {value}: give a value within its range {} .. {}",
                parameter.lower, parameter.upper
            )));
        }
    }
    let calibrate_at = section.calibrate_at.unwrap_or(sorted[0]);
    if !sizes.contains(&calibrate_at) {
        return Err(problem(format!(
            "calibrate_at = {calibrate_at} is none of the sizes {sizes:?}: the numerical uncertainty at a size comes from the study's run there; give one of them"
        )));
    }
    let size_unit = match (&section.unit, model) {
        (Some(unit), _) if unit.trim().is_empty() || unit.len() > 16 => {
            return Err(problem(format!(
                "unit = {unit:?}: give the sizes' unit in a few letters (\"mm\"), or leave it out"
            )))
        }
        (Some(unit), _) => Some(unit.clone()),
        (None, ModelKind::Builtin(builtin)) => Some(builtin.element_size_unit.to_string()),
        (None, _) => None,
    };
    Ok(Some(MeshStudySettings {
        sizes: sizes.clone(),
        at: section.at.clone().into_iter().collect(),
        calibrate_at,
        size_unit,
    }))
}

#[cfg(test)]
mod tests {
    use super::{is_slurm_memory, is_slurm_time};

    #[test]
    fn slurm_times_in_each_documented_format_and_nothing_else() {
        for good in [
            "30",
            "90",
            "5:30",
            "1:30:00",
            "2-0",
            "2-12",
            "2-12:30",
            "2-12:30:15",
            "0",
            "UNLIMITED",
            "unlimited",
            "Infinite",
            "-1",
        ] {
            assert!(is_slurm_time(good), "{good}");
        }
        for bad in [
            "",
            "1:2:3:4",
            "1::2",
            "-5",
            "5-",
            "1-2-3",
            "1:60",
            "1:30:60",
            "2-24",
            "2-1:2:3:4",
            "1h",
            " 30",
            "1.5",
            "99999999999",
        ] {
            assert!(!is_slurm_time(bad), "{bad}");
        }
    }

    #[test]
    fn slurm_memory_sizes_as_sbatch_takes_them_and_nothing_else() {
        for good in ["8G", "512M", "1024", "2t", "0"] {
            assert!(is_slurm_memory(good), "{good}");
        }
        for bad in ["lots", "", "8GB", "G", "-1", "1.5G", " 8G", "9999999999999"] {
            assert!(!is_slurm_memory(bad), "{bad}");
        }
    }
}

//! Which logged interface is which of the rig's: a logger names its
//! channels its own way (`can1` for the rig's `can0`), and two loggers may
//! both log a `can1` that are different buses. Written `[FILES:]LOGGED=RIG`
//! (`can1=can0` in every file, `logger_b:can1=can2` only in the files under
//! `logger_b`), as `acq import` and `acq lake ingest` take it and as a
//! Slurm job's command line passes it on.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use acq_can::frame::IfaceName;

/// Frames logged on `logged` are the rig's (the session's) interface
/// `session`: in every file, or only in the files under `files` (a file, or
/// a folder holding one logger's files). A mapping scoped to a file wins
/// over one for all.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BusMapping {
    pub files: Option<PathBuf>,
    pub logged: IfaceName,
    pub session: IfaceName,
}

impl BusMapping {
    /// Whether this mapping is for the file at `path` (compared as given; a
    /// leading `./` on either says nothing).
    pub fn covers(&self, path: &Path) -> bool {
        let plain = |path: &Path| -> PathBuf {
            path.components()
                .filter(|c| !matches!(c, std::path::Component::CurDir))
                .collect()
        };
        self.files
            .as_deref()
            .is_none_or(|files| plain(path).starts_with(plain(files)))
    }

    /// The `(logged, session)` pairs that hold for the file at `path`: for
    /// each logged interface the mapping scoped to the file, else the one
    /// for every file.
    pub fn for_file(mappings: &[BusMapping], path: &Path) -> Vec<(IfaceName, IfaceName)> {
        let scoped = mappings
            .iter()
            .filter(|m| m.files.is_some() && m.covers(path));
        let general = mappings.iter().filter(|m| m.files.is_none());
        let mut pairs: Vec<(IfaceName, IfaceName)> = Vec::new();
        for mapping in scoped.chain(general) {
            if !pairs.iter().any(|(logged, _)| *logged == mapping.logged) {
                pairs.push((mapping.logged, mapping.session));
            }
        }
        pairs
    }

    /// Mappings as given on a command line against the files given: one
    /// logged interface mapped twice in the same scope, or a scope that
    /// holds none of the files, is an error that says so.
    pub fn check(mappings: &[BusMapping], files: &[PathBuf]) -> Result<(), String> {
        for (index, mapping) in mappings.iter().enumerate() {
            if mappings[..index]
                .iter()
                .any(|earlier| earlier.logged == mapping.logged && earlier.files == mapping.files)
            {
                let scope = mapping
                    .files
                    .as_ref()
                    .map_or(String::new(), |files| format!("{}:", files.display()));
                return Err(format!(
                    "--bus {scope}{}=...: given twice; each logged interface maps to one interface",
                    mapping.logged
                ));
            }
            if let Some(scope) = &mapping.files {
                if !files.iter().any(|file| mapping.covers(file)) {
                    return Err(format!(
                        "--bus {mapping}: '{}' is none of the files given, nor a folder holding one; give it as the files are given",
                        scope.display()
                    ));
                }
            }
        }
        Ok(())
    }
}

/// `[FILES:]LOGGED=SESSION`, as [`FromStr`] reads it.
impl fmt::Display for BusMapping {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(files) = &self.files {
            write!(f, "{}:", files.display())?;
        }
        write!(f, "{}={}", self.logged, self.session)
    }
}

/// `can1=can0`, or `logger_b:can1=can2`. Interface names hold neither ':'
/// nor '=', so the last of each splits (a path may hold both).
impl FromStr for BusMapping {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let (left, session) = text.rsplit_once('=').ok_or_else(|| {
            format!("'{text}': expected [FILES:]LOGGED=RIG, e.g. can1=can0 or logger_b:can1=can2")
        })?;
        let (files, logged) = match left.rsplit_once(':') {
            Some(("", _)) => {
                return Err(format!(
                    "'{text}': nothing before ':'; give a file or folder, or leave out the ':'"
                ))
            }
            Some((files, logged)) => (Some(PathBuf::from(files)), logged),
            None => (None, left),
        };
        let name = |name: &str| {
            IfaceName::new(name.trim()).ok_or_else(|| {
                format!("'{name}' in '{text}': not an interface name (1 to 15 characters, no '/', ':' or space)")
            })
        };
        Ok(BusMapping {
            files,
            logged: name(logged)?,
            session: name(session)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_round_trips_and_bad_text_is_refused() {
        for text in [
            "can1=can0",
            "logger_b:can1=can2",
            "/data/a:b/x.mf4:can5=can1",
        ] {
            let mapping: BusMapping = text.parse().unwrap();
            assert_eq!(mapping.to_string(), text);
        }
        let scoped: BusMapping = "/data/a:b/x.mf4:can5=can1".parse().unwrap();
        assert_eq!(scoped.files.as_deref(), Some(Path::new("/data/a:b/x.mf4")));
        for bad in ["can1", ":can1=can0", "can1=", "a:b c=can0", "=can0"] {
            assert!(bad.parse::<BusMapping>().is_err(), "{bad}");
        }
    }

    #[test]
    fn a_scoped_mapping_wins_for_its_files_only() {
        let mappings: Vec<BusMapping> = ["can1=can0", "logger_b:can1=can2", "logger_b:can3=can1"]
            .iter()
            .map(|text| text.parse().unwrap())
            .collect();
        let name = |text: &str| IfaceName::new(text).unwrap();
        assert_eq!(
            BusMapping::for_file(&mappings, Path::new("./logger_b/day1.mf4")),
            vec![(name("can1"), name("can2")), (name("can3"), name("can1"))]
        );
        assert_eq!(
            BusMapping::for_file(&mappings, Path::new("logger_a/day1.mf4")),
            vec![(name("can1"), name("can0"))]
        );
        let files = [
            PathBuf::from("logger_a/x.mf4"),
            PathBuf::from("logger_b/y.mf4"),
        ];
        assert!(BusMapping::check(&mappings, &files).is_ok());
        let nowhere: Vec<BusMapping> = vec!["logger_c:can1=can0".parse().unwrap()];
        assert!(BusMapping::check(&nowhere, &files)
            .unwrap_err()
            .contains("'logger_c' is none of the files given"));
        let twice: Vec<BusMapping> = vec![
            "logger_a:can1=can0".parse().unwrap(),
            "logger_a:can1=can2".parse().unwrap(),
        ];
        assert!(BusMapping::check(&twice, &files)
            .unwrap_err()
            .contains("given twice"));
    }
}

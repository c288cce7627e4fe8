//! Each run's curve-part slopes (a model differentiated along with its
//! run), kept beside the evaluation log in `part_slopes.csv`: one line per
//! run, its parameter values then its slopes, appended as runs finish. A
//! resumed search reads them back, so its local steps take the same
//! models from the logged runs as the first search took and it proposes
//! the same points. The evaluation log's columns stay the observations'.

use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::Path;
use std::sync::Mutex;

/// The part slopes by run, in memory and on disk.
pub struct PartSlopesLog {
    /// By the parameter values' bits (the evaluation log writes the
    /// shortest text that reads back to the same number).
    by_values: Mutex<HashMap<Vec<u64>, Vec<f64>>>,
    file: Mutex<File>,
    parameters: usize,
}

fn key(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

impl PartSlopesLog {
    /// Opens `path` for a search over `parameter_names`: read back and
    /// appended to when `resume`, else started anew. A line a crash cut
    /// short, or one that does not read as numbers, is skipped.
    ///
    /// # Errors
    /// The file cannot be read or written.
    pub fn open(path: &Path, parameter_names: &[String], resume: bool) -> std::io::Result<Self> {
        let parameters = parameter_names.len();
        let mut by_values = HashMap::new();
        let file = if resume && path.exists() {
            let text = std::fs::read_to_string(path)?;
            for line in text.lines().skip(1) {
                let numbers: Option<Vec<f64>> =
                    line.split(',').map(|cell| cell.parse().ok()).collect();
                if let Some(numbers) = numbers.filter(|n| n.len() > parameters) {
                    let (values, slopes) = numbers.split_at(parameters);
                    by_values.insert(key(values), slopes.to_vec());
                }
            }
            // Whatever follows the last whole line is dropped.
            let whole = text.rfind('\n').map_or(0, |end| end + 1);
            let file = OpenOptions::new().write(true).open(path)?;
            file.set_len(whole as u64)?;
            let mut file = OpenOptions::new().append(true).open(path)?;
            if whole == 0 {
                writeln!(file, "{},slopes", parameter_names.join(","))?;
            }
            file
        } else {
            let mut file = File::create(path)?;
            writeln!(file, "{},slopes", parameter_names.join(","))?;
            file
        };
        Ok(PartSlopesLog {
            by_values: Mutex::new(by_values),
            file: Mutex::new(file),
            parameters,
        })
    }

    /// Keeps a run's slopes, and appends them to the file. A line that
    /// cannot be written costs a resumed search that run's slopes only
    /// (its local steps then fit their model to the runs), so it is not an
    /// error of the run.
    pub fn record(&self, values: &[f64], slopes: Vec<f64>) {
        if values.len() != self.parameters {
            return;
        }
        let mut buffer = ryu::Buffer::new();
        let mut line = String::new();
        for (i, number) in values.iter().chain(&slopes).enumerate() {
            if i > 0 {
                line.push(',');
            }
            line.push_str(buffer.format(*number));
        }
        line.push('\n');
        if let Ok(mut file) = self.file.lock() {
            let _ = file.write_all(line.as_bytes());
        }
        if let Ok(mut by_values) = self.by_values.lock() {
            by_values.insert(key(values), slopes);
        }
    }

    /// The slopes of the run at `values`, once; empty when it gave none.
    pub fn take(&self, values: &[f64]) -> Vec<f64> {
        self.by_values
            .lock()
            .map(|mut by_values| by_values.remove(&key(values)).unwrap_or_default())
            .unwrap_or_default()
    }
}

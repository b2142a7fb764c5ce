//! A small reader for the recordings' numeric CSV files: a header row of column names, then
//! rows of numbers. Columns are found by name (so a user's file may order them freely or add
//! others), and every error names the file, the line and the column.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why a CSV file could not be read.
#[derive(Debug)]
pub enum CsvError {
    /// The file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file has no header row.
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A required column is missing from the header.
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column's name.
        column: &'static str,
    },
    /// A cell is not a number.
    BadNumber {
        /// The file.
        path: PathBuf,
        /// Line number, 1-based (the header is line 1).
        line: usize,
        /// The column's name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// A cell that must hold a value is empty.
    MissingValue {
        /// The file.
        path: PathBuf,
        /// Line number, 1-based.
        line: usize,
        /// The column's name.
        column: &'static str,
    },
}

impl fmt::Display for CsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CsvError::Io { path, source } => write!(f, "cannot read {}: {source}", path.display()),
            CsvError::Empty { path } => write!(
                f,
                "{} is empty: it needs a header row of column names",
                path.display()
            ),
            CsvError::MissingColumn { path, column } => write!(
                f,
                "{} has no column `{column}` (see README.txt of a recording for the columns)",
                path.display()
            ),
            CsvError::BadNumber {
                path,
                line,
                column,
                text,
            } => write!(
                f,
                "{} line {line}, column `{column}`: `{text}` is not a finite number",
                path.display()
            ),
            CsvError::MissingValue { path, line, column } => write!(
                f,
                "{} line {line}: column `{column}` is empty, and it needs a value",
                path.display()
            ),
        }
    }
}

impl std::error::Error for CsvError {}

/// A numeric CSV table: named columns, rows of `f64` (an empty cell reads as NaN, "no
/// value"; a written `NaN` or `inf` is refused: a measurement is finite).
#[derive(Debug, Clone, PartialEq)]
pub struct CsvTable {
    path: PathBuf,
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
    /// The file's line number (1-based) of each row.
    lines: Vec<usize>,
}

impl CsvTable {
    /// Reads a file. Blank lines and lines starting with `#` are skipped.
    pub fn read(path: &Path) -> Result<Self, CsvError> {
        let text = std::fs::read_to_string(path).map_err(|source| CsvError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(path, &text)
    }

    /// Reads a file of which only the `numeric` columns are numbers (others, e.g. a status
    /// label, are read as "no value" and never refused).
    pub fn read_columns(path: &Path, numeric: &[&str]) -> Result<Self, CsvError> {
        let text = std::fs::read_to_string(path).map_err(|source| CsvError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse_with(path, &text, Some(numeric))
    }

    /// Parses text; `path` only names the source in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Self, CsvError> {
        Self::parse_with(path, text, None)
    }

    /// Parses text, every column as numbers or (`Some`) only the named ones.
    fn parse_with(path: &Path, text: &str, numeric: Option<&[&str]>) -> Result<Self, CsvError> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((_, header)) = lines.next() else {
            return Err(CsvError::Empty {
                path: path.to_path_buf(),
            });
        };
        let names: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
        let is_numeric: Vec<bool> = names
            .iter()
            .map(|n| numeric.is_none_or(|keep| keep.contains(&n.as_str())))
            .collect();
        let mut rows = Vec::new();
        let mut row_lines = Vec::new();
        for (i, line) in lines {
            row_lines.push(i + 1);
            let mut row = Vec::with_capacity(names.len());
            for (k, cell) in line.split(',').enumerate() {
                let cell = cell.trim();
                let v = if cell.is_empty() || !is_numeric.get(k).copied().unwrap_or(true) {
                    f64::NAN
                } else {
                    cell.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| CsvError::BadNumber {
                            path: path.to_path_buf(),
                            line: i + 1,
                            column: names
                                .get(k)
                                .cloned()
                                .unwrap_or_else(|| format!("#{}", k + 1)),
                            text: cell.to_string(),
                        })?
                };
                row.push(v);
            }
            row.resize(names.len(), f64::NAN);
            rows.push(row);
        }
        Ok(Self {
            path: path.to_path_buf(),
            names,
            rows,
            lines: row_lines,
        })
    }

    /// Index of a required column.
    pub fn column(&self, name: &'static str) -> Result<usize, CsvError> {
        self.optional_column(name)
            .ok_or_else(|| CsvError::MissingColumn {
                path: self.path.clone(),
                column: name,
            })
    }

    /// Index of a column, if present.
    pub fn optional_column(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// The rows.
    pub fn rows(&self) -> &[Vec<f64>] {
        &self.rows
    }

    /// The file's line number (1-based) of row `row` (0-based); 0 past the last row.
    pub fn line(&self, row: usize) -> usize {
        self.lines.get(row).copied().unwrap_or(0)
    }

    /// The file the table came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The value of column `name` in row `row` (0-based), which must be there: a missing
    /// column or an empty cell is an error naming the file and the line.
    pub fn value(&self, row: usize, name: &'static str) -> Result<f64, CsvError> {
        let c = self.column(name)?;
        let v = self.rows.get(row).map_or(f64::NAN, |r| cell(r, c));
        if v.is_finite() {
            Ok(v)
        } else {
            Err(CsvError::MissingValue {
                path: self.path.clone(),
                line: self.line(row),
                column: name,
            })
        }
    }
}

/// The value at `row[col]` (NaN when the row is short).
pub fn cell(row: &[f64], col: usize) -> f64 {
    row.get(col).copied().unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_by_name_and_errors_that_say_where() {
        let p = Path::new("odometry.csv");
        let t = CsvTable::parse(p, "# comment\nb_m,a_s\n2.5,1\n\n3,\n").unwrap();
        let a = t.column("a_s").unwrap();
        assert_eq!(t.rows().len(), 2);
        assert_eq!(cell(&t.rows()[0], a), 1.0);
        assert!(cell(&t.rows()[1], a).is_nan());
        let e = t.column("c").unwrap_err().to_string();
        assert!(e.contains("odometry.csv") && e.contains("`c`"), "{e}");
        let e = CsvTable::parse(p, "a\n1\nx1\n").unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("`x1`"), "{e}");
        assert!(matches!(
            CsvTable::parse(p, "\n# only\n"),
            Err(CsvError::Empty { .. })
        ));
    }
}

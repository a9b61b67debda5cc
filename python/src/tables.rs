//! The tables of a run as columns for pandas: the very cells the CSV files
//! hold ([`sonarnet::pipeline::TableSink`]), typed as `pandas.read_csv`
//! types them, and handed to numpy without a copy.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarnet::pipeline::{RunError, TableSink};

/// A table for Python: its name, its column names, and its columns by name.
pub type PyTable<'py> = (String, Vec<String>, Bound<'py, PyDict>);

/// One table: its name, column names and cells, column by column.
struct Table {
    name: String,
    header: Vec<String>,
    columns: Vec<Vec<String>>,
}

/// A sink that keeps tables in memory: every table, or only the one named
/// (the others' rows are never made).
#[derive(Default)]
pub struct Columns {
    tables: Vec<Table>,
    only: Option<String>,
    /// The name of every table offered, kept or not.
    pub names: Vec<String>,
}

impl Columns {
    /// A sink that keeps table `name` only.
    pub fn only(name: &str) -> Self {
        Columns {
            only: Some(name.to_string()),
            ..Columns::default()
        }
    }
}

impl TableSink for Columns {
    fn table(
        &mut self,
        name: &str,
        header: &[&str],
        rows: &mut dyn Iterator<Item = Vec<String>>,
    ) -> Result<(), RunError> {
        self.names.push(name.to_string());
        if self.only.as_deref().is_some_and(|o| o != name) {
            return Ok(());
        }
        let mut columns: Vec<Vec<String>> = vec![Vec::new(); header.len()];
        for row in rows {
            for (c, cell) in columns.iter_mut().zip(row) {
                c.push(cell);
            }
        }
        self.tables.push(Table {
            name: name.to_string(),
            header: header.iter().map(|h| h.to_string()).collect(),
            columns,
        });
        Ok(())
    }
}

/// A column's type, as `pandas.read_csv` infers it from the same cells.
enum Typed {
    Int(Vec<i64>),
    Float(Vec<f64>),
    Bool(Vec<bool>),
    Text(Vec<Option<String>>),
}

/// Type a column: integers (int64; float64 with NaN if a cell is empty),
/// `true`/`false` (bool), floats (empty cells NaN), else text (empty cells
/// None). The CSV's floats are shortest round-trip decimals, so parsing
/// them back gives the very bits the library computed.
fn typed(cells: Vec<String>) -> Typed {
    let empty = cells.iter().any(String::is_empty);
    let full = || cells.iter().filter(|c| !c.is_empty());
    if !cells.is_empty() && full().count() > 0 {
        if !empty && let Ok(v) = cells.iter().map(|c| c.parse::<i64>()).collect() {
            return Typed::Int(v);
        }
        if !empty && cells.iter().all(|c| c == "true" || c == "false") {
            return Typed::Bool(cells.iter().map(|c| c == "true").collect());
        }
        if full().all(|c| c.parse::<f64>().is_ok()) {
            return Typed::Float(
                cells
                    .iter()
                    .map(|c| c.parse::<f64>().unwrap_or(f64::NAN))
                    .collect(),
            );
        }
    } else if !cells.is_empty() {
        // Every cell empty: pandas reads a column of NaN.
        return Typed::Float(vec![f64::NAN; cells.len()]);
    }
    Typed::Text(
        cells
            .into_iter()
            .map(|c| (!c.is_empty()).then_some(c))
            .collect(),
    )
}

impl Columns {
    /// Every table as `(name, column names, {column: array})`: numpy arrays
    /// that own the Rust vectors (no copy) for numbers and booleans, lists
    /// for text.
    pub fn into_python(self, py: Python<'_>) -> PyResult<Vec<PyTable<'_>>> {
        let mut out = Vec::new();
        for t in self.tables {
            let d = PyDict::new(py);
            for (h, c) in t.header.iter().zip(t.columns) {
                match typed(c) {
                    Typed::Int(v) => d.set_item(h, PyArray1::from_vec(py, v))?,
                    Typed::Float(v) => d.set_item(h, PyArray1::from_vec(py, v))?,
                    Typed::Bool(v) => d.set_item(h, PyArray1::from_vec(py, v))?,
                    Typed::Text(v) => d.set_item(h, v)?,
                }
            }
            out.push((t.name, t.header, d));
        }
        Ok(out)
    }
}

//! The committed tables of `validation/`, read by the tests that compare the crate with them:
//! CSV with a fixed header and a number in every field. Test-only.

/// The validation's largest relative difference from a reference for an optically thin medium:
/// the ground-truth target for decks of optical depth 0.5, which the haze (thinner still) is
/// held to as well.
pub(crate) const THIN_MEDIUM_TOLERANCE: f64 = 0.10;

/// The rows of `text` (the contents of `file`): the header must be `header`, every field a
/// finite number, every row `columns` fields; `row` turns each row (its number, 1 being the
/// header, and its values) into a case or an error. Blank lines are skipped. Every error names
/// the file and, for a row, the row; a table without rows is an error too.
pub(crate) fn parse_table<T>(
    file: &str,
    text: &str,
    header: &str,
    columns: usize,
    mut row: impl FnMut(usize, &[f64]) -> Result<T, String>,
) -> Result<Vec<T>, String> {
    let mut lines = text.lines();
    match lines.next() {
        Some(first) if first.trim() == header => {}
        Some(first) => {
            return Err(format!(
                "{file}: row 1: header {first:?}, expected {header:?}"
            ));
        }
        None => return Err(format!("{file}: empty")),
    }
    let cases: Vec<T> = lines
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| {
            let number = i + 2;
            let values: Vec<f64> = line
                .split(',')
                .map(|field| {
                    field
                        .trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| format!("{file}: row {number}: {field:?} is not a number"))
                })
                .collect::<Result<_, _>>()?;
            if values.len() != columns {
                return Err(format!(
                    "{file}: row {number}: {} fields, expected {columns}",
                    values.len()
                ));
            }
            row(number, &values).map_err(|error| format!("{file}: row {number}: {error}"))
        })
        .collect::<Result<_, _>>()?;
    if cases.is_empty() {
        return Err(format!("{file}: no cases"));
    }
    Ok(cases)
}

/// The committed table at `relative` (a path from the crate root), parsed by `parse` (the
/// test's [`parse_table`] call, given the path and the file's text). A file that cannot be read
/// or parsed panics with the path and, for a row, the row: the test fails naming them.
pub(crate) fn read_committed<T>(
    relative: &str,
    parse: impl FnOnce(&str, &str) -> Result<Vec<T>, String>,
) -> Vec<T> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|error| panic!("{relative}: cannot be read ({error})"));
    parse(relative, &text).unwrap_or_else(|error| panic!("{error}"))
}

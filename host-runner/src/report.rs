//! What the commands write besides their summary lines: the JSON reports.

use crate::error::CliError;

/// Writes `value` as pretty JSON to `path` (exit 1 on an I/O error: the run itself is fine).
pub fn write_json<T: serde::Serialize>(path: &std::path::Path, value: &T) -> Result<(), CliError> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| CliError::failure(format!("cannot encode JSON: {e}")))?;
    std::fs::write(path, text + "\n")
        .map_err(|e| CliError::failure(format!("{}: cannot write: {e}", path.display())))
}

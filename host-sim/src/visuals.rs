//! What a person looks at after a run or a replay, written into its `--out` directory: the
//! plots ([`crate::plot`]) and the MCAP file for Foxglove Studio ([`crate::mcap_out`]).

use std::path::{Path, PathBuf};

use loc_core::map::TunnelMap;

use crate::closed_loop::RunLog;
use crate::plot::map_lines::MapLines;
use crate::plot::{self};

/// Writes the plots (PNG and SVG) and `run.mcap` of `log` over `map` into `dir` (created if
/// needed). The MCAP file has scans only if the run kept them. Returns the files written.
pub fn write_visuals(dir: &Path, log: &RunLog, map: &TunnelMap) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let lines = MapLines::of(map);
    let mut files = plot::write_plots(dir, log, &lines).map_err(|e| e.to_string())?;
    let mcap = dir.join(crate::mcap_out::FILE_NAME);
    crate::mcap_out::write_mcap(&mcap, log, &lines).map_err(|e| e.to_string())?;
    files.push(mcap);
    Ok(files)
}

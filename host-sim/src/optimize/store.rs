//! A search's directory (`optimize --out DIR`): what it was asked, every evaluation as it
//! finishes, each generation, and the cluster's work files.
//!
//! | file | holds |
//! |---|---|
//! | `search.json` | the search's settings ([`SearchSpec`]) |
//! | `scenario.toml` | the scenario every evaluation runs (a CSV centre line copied beside it) |
//! | `evaluations.csv` | one line per finished evaluation: genes, fitness (appended and flushed, so Ctrl-C loses nothing) |
//! | `population-NNN.csv` | generation NNN: its individuals, their fitness, rank |
//! | `generations.csv` | per generation: best genes and fitness, median, new evaluations |
//! | `pending.csv` | (cluster) the gene vectors the next generation still needs |
//! | `shards/shard-I-of-N.csv` | (cluster) one array task's evaluations of `pending.csv` |
//!
//! Numbers are written with Rust's shortest round-trip formatting, so a value read back is
//! the very same `f64`: a resumed or merged search continues bit for bit.

use std::fmt::Write as _;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::output::OutputError;
use crate::scenario::Scenario;

use super::ga::{EvaluationCache, GaSettings, Generation};
use super::genes::{GeneSpace, Genes};
use super::stopping::StoppingRule;

/// Everything a search depends on besides the scenario (`search.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchSpec {
    /// Landmark model code, `P1`…`F4`.
    pub model: String,
    /// Individuals per generation.
    pub population: usize,
    /// Share kept unchanged.
    pub elite_fraction: f64,
    /// Share of the rest made by crossover.
    pub crossover_fraction: f64,
    /// Generations at most.
    pub max_generations: usize,
    /// Window of the stopping rule, generations.
    pub stall_generations: usize,
    /// Tolerance of the average relative decrease.
    pub tolerance: f64,
    /// Seed of the GA's draws and of every evaluation.
    pub seed: u64,
    /// Fresh seeds the best genome is validated on when the search ends.
    pub validation_seeds: usize,
    /// Simulated runs averaged in each fitness (1: the paper's; more penalises a design
    /// that fails on some seeds, at that many times the cost).
    #[serde(default = "one_run")]
    pub runs_per_evaluation: usize,
    /// What the fitness is.
    #[serde(default)]
    pub objective: super::fitness::ObjectiveKind,
}

fn one_run() -> usize {
    1
}

impl SearchSpec {
    /// The seeds of every fitness: the search's seed, then `seed + 1000 k` (clear of the
    /// validation seeds `seed + 1 …`).
    pub fn evaluation_seeds(&self) -> Vec<u64> {
        (0..self.runs_per_evaluation.max(1) as u64)
            .map(|k| self.seed.wrapping_add(1000 * k))
            .collect()
    }

    /// The GA settings.
    pub fn ga(&self) -> GaSettings {
        GaSettings {
            population: self.population,
            elite_fraction: self.elite_fraction,
            crossover_fraction: self.crossover_fraction,
            stopping: StoppingRule {
                max_generations: self.max_generations,
                window: self.stall_generations,
                tolerance: self.tolerance,
            },
            seed: self.seed,
        }
    }
}

/// A search directory.
#[derive(Debug, Clone)]
pub struct Store {
    /// The directory.
    pub dir: PathBuf,
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |e| OutputError::new(path, e)
}

/// `genes` and `fitness` as one CSV line (no newline).
fn csv_line(genes: &[f64], tail: &[f64]) -> String {
    let mut s = String::new();
    for (k, v) in genes.iter().chain(tail).enumerate() {
        if k > 0 {
            s.push(',');
        }
        let _ = write!(s, "{v}");
    }
    s
}

fn header(space: &GeneSpace, tail: &[&str]) -> String {
    let mut names: Vec<String> = (0..space.len())
        .map(|i| format!("{}_{}", space.name(i), space.unit(i)))
        .collect();
    names.extend(tail.iter().map(|s| s.to_string()));
    names.join(",")
}

impl Store {
    /// Creates the directory for a new search: refuses one that already holds a search.
    pub fn create(dir: &Path, spec: &SearchSpec, scenario: &Scenario) -> Result<Self, OutputError> {
        let settings = dir.join("search.json");
        if settings.exists() {
            return Err(OutputError::new(
                &settings,
                "a search is already in this directory: continue it with --resume, or choose another --out",
            ));
        }
        fs::create_dir_all(dir).map_err(io_err(dir))?;
        let json =
            serde_json::to_string_pretty(spec).map_err(|e| OutputError::new(&settings, e))?;
        fs::write(&settings, json).map_err(io_err(&settings))?;
        scenario
            .write_self_contained(dir, "")
            .map_err(|e| OutputError::new(&dir.join("scenario.toml"), e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    /// Opens a search directory: its settings and the scenario as written.
    pub fn open(dir: &Path) -> Result<(Self, SearchSpec, Scenario), OutputError> {
        let settings = dir.join("search.json");
        let text = fs::read_to_string(&settings).map_err(|e| {
            OutputError::new(
                &settings,
                format!("{e}: not a search directory (start one with --out)"),
            )
        })?;
        let spec: SearchSpec =
            serde_json::from_str(&text).map_err(|e| OutputError::new(&settings, e))?;
        let toml = dir.join("scenario.toml");
        let scenario = Scenario::from_file(&toml).map_err(|e| OutputError::new(&toml, e))?;
        Ok((
            Self {
                dir: dir.to_path_buf(),
            },
            spec,
            scenario,
        ))
    }

    fn evaluations_path(&self) -> PathBuf {
        self.dir.join("evaluations.csv")
    }

    /// Every evaluation recorded so far, and those of merged shards.
    pub fn load_cache(&self, space: &GeneSpace) -> Result<EvaluationCache, OutputError> {
        let mut cache = EvaluationCache::default();
        let path = self.evaluations_path();
        if path.exists() {
            for row in read_rows(&path, space.len() + 1, true)? {
                cache.insert(&row[..space.len()], row[space.len()]);
            }
        }
        Ok(cache)
    }

    /// The appender of `evaluations.csv` (shared by the evaluation threads).
    pub fn evaluation_log(&self, space: &GeneSpace) -> Result<EvaluationLog, OutputError> {
        let path = self.evaluations_path();
        let new = !path.exists();
        let mut file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        if new {
            writeln!(file, "{}", header(space, &["fitness_mse"])).map_err(io_err(&path))?;
        }
        Ok(EvaluationLog {
            path,
            file: Mutex::new(file),
        })
    }

    /// Writes `population-NNN.csv` of a scored generation.
    pub fn write_generation(&self, space: &GeneSpace, g: &Generation) -> Result<(), OutputError> {
        let path = self.dir.join(format!("population-{:03}.csv", g.index));
        let mut rank = vec![0usize; g.fitness.len()];
        for (r, i) in super::operators::ranking(&g.fitness)
            .into_iter()
            .enumerate()
        {
            rank[i] = r + 1;
        }
        let mut text = header(space, &["fitness_mse", "rank"]) + "\n";
        for ((genes, f), r) in g.population.iter().zip(&g.fitness).zip(rank) {
            text += &csv_line(genes, &[*f, r as f64]);
            text.push('\n');
        }
        fs::write(&path, text).map_err(io_err(&path))
    }

    /// Reads back a generation's population and fitness (for the figures).
    pub fn read_generation(
        &self,
        space: &GeneSpace,
        index: usize,
    ) -> Result<(Vec<Genes>, Vec<f64>), OutputError> {
        let path = self.dir.join(format!("population-{index:03}.csv"));
        let rows = read_rows(&path, space.len() + 2, false)?;
        Ok(rows
            .into_iter()
            .map(|r| (r[..space.len()].to_vec(), r[space.len()]))
            .unzip())
    }

    /// Writes `generations.csv` from the best and median of each generation.
    pub fn write_generations(
        &self,
        space: &GeneSpace,
        rows: &[GenerationRow],
    ) -> Result<PathBuf, OutputError> {
        let path = self.dir.join("generations.csv");
        let mut text = String::from(
            "generation,new_evaluations,best_fitness_mse,best_rms_eq2,median_fitness_mse",
        );
        for i in 0..space.len() {
            let _ = write!(text, ",best_{}_{}", space.name(i), space.unit(i));
        }
        text.push('\n');
        for r in rows {
            let _ = write!(text, "{},{},", r.index, r.new_evaluations);
            text += &csv_line(
                &[r.best_fitness, r.best_fitness.sqrt(), r.median_fitness],
                &r.best,
            );
            text.push('\n');
        }
        fs::write(&path, text).map_err(io_err(&path))?;
        Ok(path)
    }

    /// Writes `pending.csv`: the gene vectors the search needs next.
    pub fn write_pending(
        &self,
        space: &GeneSpace,
        pending: &[Genes],
    ) -> Result<PathBuf, OutputError> {
        let path = self.dir.join("pending.csv");
        let mut text = header(space, &[]) + "\n";
        for g in pending {
            text += &csv_line(g, &[]);
            text.push('\n');
        }
        fs::write(&path, text).map_err(io_err(&path))?;
        Ok(path)
    }

    /// Reads `pending.csv`.
    pub fn read_pending(&self, space: &GeneSpace) -> Result<Vec<Genes>, OutputError> {
        read_rows(&self.dir.join("pending.csv"), space.len(), false)
    }

    /// Path of shard `i` of `n`'s results.
    pub fn shard_path(&self, shard: Shard) -> PathBuf {
        self.dir
            .join("shards")
            .join(format!("shard-{}-of-{}.csv", shard.index, shard.count))
    }

    /// Opens the results file of one shard (replacing an earlier attempt's).
    pub fn shard_log(&self, space: &GeneSpace, shard: Shard) -> Result<EvaluationLog, OutputError> {
        let path = self.shard_path(shard);
        let dir = self.dir.join("shards");
        fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        let mut file = File::create(&path).map_err(io_err(&path))?;
        writeln!(file, "{}", header(space, &["fitness_mse"])).map_err(io_err(&path))?;
        Ok(EvaluationLog {
            path,
            file: Mutex::new(file),
        })
    }

    /// Moves every shard's results into `evaluations.csv` and removes the shard files and
    /// `pending.csv`. Returns the evaluations merged; refuses when a pending genome has no
    /// result in any shard (a failed array task: run it again).
    pub fn merge_shards(&self, space: &GeneSpace) -> Result<usize, OutputError> {
        let dir = self.dir.join("shards");
        let pending = self.read_pending(space)?;
        let mut merged = EvaluationCache::default();
        let mut files = Vec::new();
        if dir.exists() {
            for entry in fs::read_dir(&dir).map_err(io_err(&dir))? {
                let path = entry.map_err(io_err(&dir))?.path();
                if path.extension().is_some_and(|e| e == "csv") {
                    for row in read_rows(&path, space.len() + 1, true)? {
                        merged.insert(&row[..space.len()], row[space.len()]);
                    }
                    files.push(path);
                }
            }
        }
        if let Some(missing) = pending.iter().position(|g| merged.get(g).is_none()) {
            return Err(OutputError::new(
                &dir,
                format!(
                    "pending genome {} (line {} of pending.csv) has no result in any shard: run its array task again",
                    csv_line(&pending[missing], &[]),
                    missing + 2
                ),
            ));
        }
        let log = self.evaluation_log(space)?;
        for g in &pending {
            if let Some(f) = merged.get(g) {
                log.record(g, f)?;
            }
        }
        for f in files {
            fs::remove_file(&f).map_err(io_err(&f))?;
        }
        let p = self.dir.join("pending.csv");
        fs::remove_file(&p).map_err(io_err(&p))?;
        Ok(pending.len())
    }
}

/// Reads rows of `width` numbers after a header line; the error names the file and line.
/// With `cut_last_line_ok`, a last line without its newline (a write interrupted by Ctrl-C
/// or a killed task) is dropped instead: that evaluation is simply run again.
fn read_rows(
    path: &Path,
    width: usize,
    cut_last_line_ok: bool,
) -> Result<Vec<Vec<f64>>, OutputError> {
    let text = fs::read_to_string(path).map_err(io_err(path))?;
    let complete = match (cut_last_line_ok, text.rfind('\n')) {
        (false, _) => text.as_str(),
        (true, Some(end)) => &text[..=end],
        (true, None) => "",
    };
    let mut rows = Vec::new();
    for (n, line) in complete.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let row: Option<Vec<f64>> = line.split(',').map(|v| v.trim().parse().ok()).collect();
        match row {
            Some(r) if r.len() == width => rows.push(r),
            _ => {
                return Err(OutputError::new(
                    path,
                    format!("line {}: expected {width} numbers: `{line}`", n + 1),
                ))
            }
        }
    }
    Ok(rows)
}

/// The best and median of one generation, for `generations.csv` and the figures.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerationRow {
    /// Generation index, 0 first.
    pub index: usize,
    /// Gene vectors first evaluated in it.
    pub new_evaluations: usize,
    /// Best fitness (MSE of eq. 2).
    pub best_fitness: f64,
    /// The best's genes.
    pub best: Genes,
    /// Median fitness.
    pub median_fitness: f64,
}

impl GenerationRow {
    /// The row of a scored generation.
    pub fn of(g: &Generation) -> Self {
        let (best, best_fitness) = g.best();
        Self {
            index: g.index,
            new_evaluations: g.new_evaluations,
            best_fitness,
            best: best.clone(),
            median_fitness: g.median().1,
        }
    }
}

/// An append-only evaluation file, one flushed line per evaluation.
#[derive(Debug)]
pub struct EvaluationLog {
    path: PathBuf,
    file: Mutex<File>,
}

impl EvaluationLog {
    /// Appends one evaluation and flushes it.
    pub fn record(&self, genes: &[f64], fitness: f64) -> Result<(), OutputError> {
        let line = csv_line(genes, &[fitness]) + "\n";
        let mut f = self
            .file
            .lock()
            .map_err(|_| OutputError::new(&self.path, "a writer thread panicked"))?;
        f.write_all(line.as_bytes())
            .and_then(|()| f.flush())
            .map_err(io_err(&self.path))
    }
}

/// One shard of a generation's pending work: every `count`-th pending genome from `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based shard index.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Parses `I/N` (0 ≤ I < N).
    pub fn parse(text: &str) -> Result<Self, String> {
        let (i, n) = text
            .split_once('/')
            .ok_or_else(|| format!("--shard `{text}`: write it as I/N, e.g. 0/4"))?;
        let index: usize = i
            .trim()
            .parse()
            .map_err(|_| format!("--shard `{text}`: `{i}` is not a shard index"))?;
        let count: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("--shard `{text}`: `{n}` is not a shard count"))?;
        if count == 0 || index >= count {
            return Err(format!(
                "--shard `{text}`: the index must be below the count (0/{count} … {}/{count})",
                count.saturating_sub(1)
            ));
        }
        Ok(Self { index, count })
    }

    /// Which of `len` pending genomes this shard evaluates.
    pub fn members(&self, len: usize) -> impl Iterator<Item = usize> {
        (self.index..len).step_by(self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::landmark::LandmarkModel;

    fn spec() -> SearchSpec {
        SearchSpec {
            model: "P1".into(),
            population: 10,
            elite_fraction: 0.05,
            crossover_fraction: 0.75,
            max_generations: 5,
            stall_generations: 10,
            tolerance: 0.001,
            seed: 3,
            validation_seeds: 3,
            runs_per_evaluation: 1,
            objective: Default::default(),
        }
    }

    #[test]
    fn evaluations_round_trip_bit_for_bit_and_a_cut_line_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let scenario = crate::scenario::named::named("paper-10m").unwrap();
        let store = Store::create(dir.path(), &spec(), &scenario).unwrap();
        assert!(Store::create(dir.path(), &spec(), &scenario).is_err());
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let log = store.evaluation_log(&space).unwrap();
        let g = vec![0.1 + 0.2, 1.0 / 3.0, 9.123456789012345];
        log.record(&g, 1.234e-7).unwrap();
        log.record(&[0.5, 0.25, 9.5], f64::INFINITY).unwrap();
        drop(log);
        // An interrupted write leaves half a line.
        let mut f = OpenOptions::new()
            .append(true)
            .open(store.evaluations_path())
            .unwrap();
        write!(f, "0.4,0.2").unwrap();
        let cache = store.load_cache(&space).unwrap();
        assert_eq!(cache.len(), 2);
        assert_eq!(cache.get(&g).unwrap().to_bits(), 1.234e-7f64.to_bits());
        assert_eq!(cache.get(&[0.5, 0.25, 9.5]), Some(f64::INFINITY));
        let (_, s, sc) = Store::open(dir.path()).unwrap();
        assert_eq!(s, spec());
        assert_eq!(sc.to_toml(), scenario.to_toml());
    }

    #[test]
    fn shards_cover_the_pending_work_once_and_merge_checks_completeness() {
        let dir = tempfile::tempdir().unwrap();
        let scenario = crate::scenario::named::named("paper-10m").unwrap();
        let store = Store::create(dir.path(), &spec(), &scenario).unwrap();
        let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
        let pending: Vec<Genes> = (0..7).map(|k| vec![0.1, 0.1, 2.0 + k as f64]).collect();
        store.write_pending(&space, &pending).unwrap();
        assert_eq!(store.read_pending(&space).unwrap(), pending);
        let mut seen: Vec<usize> = Vec::new();
        for i in 0..3 {
            seen.extend(Shard { index: i, count: 3 }.members(7));
        }
        seen.sort();
        assert_eq!(seen, (0..7).collect::<Vec<_>>());
        // Two of three shards done: merge refuses and names a missing genome.
        for i in 0..2 {
            let s = Shard { index: i, count: 3 };
            let log = store.shard_log(&space, s).unwrap();
            for k in s.members(7) {
                log.record(&pending[k], k as f64).unwrap();
            }
        }
        let e = store.merge_shards(&space).unwrap_err();
        assert!(e.reason.contains("array task"), "{e}");
        let s = Shard { index: 2, count: 3 };
        let log = store.shard_log(&space, s).unwrap();
        for k in s.members(7) {
            log.record(&pending[k], k as f64).unwrap();
        }
        assert_eq!(store.merge_shards(&space).unwrap(), 7);
        let cache = store.load_cache(&space).unwrap();
        assert_eq!(cache.get(&pending[5]), Some(5.0));
        assert!(!dir.path().join("pending.csv").exists());
    }

    #[test]
    fn shard_parsing() {
        assert_eq!(Shard::parse("2/4").unwrap(), Shard { index: 2, count: 4 });
        assert!(Shard::parse("4/4").is_err());
        assert!(Shard::parse("x/4").is_err());
        assert!(Shard::parse("3").is_err());
        assert!(Shard::parse("0/0").is_err());
    }
}

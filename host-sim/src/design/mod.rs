//! `host-sim design`: what an engineer takes underground for a landmark design — the
//! installation schedule, a 1:1 cutting template, a bill of materials, the map file the
//! firmware loads, and the predicted accuracy along the tunnel.
//!
//! - [`spacing`]: spacings drawn so that every window of a few consecutive spacings is
//!   unique along each wall (a vehicle that has seen them knows where it is).
//! - [`template_svg`]: the profile at 1:1 in millimetres.
//! - [`accuracy`]: the per-scan bound along the tunnel, the stretches above the target.

pub mod accuracy;
pub mod spacing;
pub mod template_svg;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use loc_core::rng::Pcg32;
use serde::Serialize;

use crate::landmarks::LandmarkChoice;
use crate::scenario::Scenario;
use crate::stored_map;
use crate::world::layout::{Condition, Placement, WallChoice, WallSide};
use crate::world::World;
use accuracy::{AccuracyPoint, Stretch};

/// What to design.
#[derive(Debug, Clone)]
pub struct DesignRequest {
    /// The tunnel (centre line, width, roughness), lidar and localiser; its landmark section
    /// gives the walls and the first chainage.
    pub scenario: Scenario,
    /// The landmark model and genes.
    pub choice: LandmarkChoice,
    /// Target 1σ along-tunnel accuracy of one scan, metres.
    pub target_along_m: f64,
    /// Consecutive spacings that must identify a position.
    pub window: usize,
    /// Spacings closer than this are indistinguishable, metres.
    pub tolerance_m: f64,
    /// Height of the LMS511's scan plane above the floor: where the landmarks are
    /// mounted, metres.
    pub mounting_height_m: f64,
    /// Vertical extent of each landmark (the profile is extruded over it), metres.
    pub landmark_depth_m: f64,
    /// Chainage step of the predicted accuracy, metres.
    pub step_m: f64,
    /// Seed of the spacing draw.
    pub seed: u64,
}

/// The bill of materials.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BillOfMaterials {
    /// Landmarks to make.
    pub count: usize,
    /// Developed length of one profile (the face to bend or cut), metres.
    pub profile_length_m: f64,
    /// All profiles together, metres.
    pub total_profile_length_m: f64,
    /// Sheet area: total profile length × landmark depth, m².
    pub sheet_area_m2: f64,
}

/// The design's summary (`design.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignReport {
    /// Model code.
    pub model: String,
    /// Genes W, H, D[, h1…h6].
    pub genes: Vec<f64>,
    /// Tunnel length, metres.
    pub tunnel_length_m: f64,
    /// Landmarks per wall (left, right).
    pub landmarks_per_wall: (usize, usize),
    /// The shortest window of spacings that identifies every position, per wall.
    pub shortest_unique_window: (Option<usize>, Option<usize>),
    /// The tolerance of that check, metres.
    pub spacing_tolerance_m: f64,
    /// The bill of materials.
    pub bill_of_materials: BillOfMaterials,
    /// The target, metres.
    pub target_along_m: f64,
    /// The largest along bound over the tunnel, metres.
    pub worst_along_sd_m: f64,
    /// The mean along bound, metres.
    pub mean_along_sd_m: f64,
    /// Where the along bound exceeds the target.
    pub stretches_above_target: Vec<Stretch>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The chainages of each wall's landmarks, unique windows kept.
fn layout(req: &DesignRequest, length_m: f64) -> Result<Vec<Placement>, String> {
    let d = req.choice.spacing_m();
    let half_w = req
        .choice
        .profile()
        .iter()
        .map(|p| p.0.abs())
        .fold(0.0, f64::max);
    let l = &req.scenario.landmarks;
    let mut rng = Pcg32::new(req.seed, 0xde51);
    let mut out = Vec::new();
    let walls: &[(WallSide, f64)] = match l.walls {
        WallChoice::Left => &[(WallSide::Left, 0.0)],
        WallChoice::Right => &[(WallSide::Right, 0.0)],
        WallChoice::Both => &[(WallSide::Left, 0.0), (WallSide::Right, 0.5)],
    };
    for &(wall, stagger) in walls {
        let first = l.first_m + if l.stagger { stagger * d } else { 0.0 };
        let s = spacing::draw_unique(
            d,
            first,
            length_m - half_w,
            req.window,
            req.tolerance_m,
            &mut rng,
        )
        .map_err(|e| format!("{wall:?} wall: {e}"))?;
        out.extend(
            s.into_iter()
                .map(|s_m| Placement::at_mark(wall, s_m, Condition::Intact)),
        );
    }
    Ok(out)
}

fn spacings(placements: &[Placement], wall: WallSide) -> Vec<f64> {
    let s: Vec<f64> = placements
        .iter()
        .filter(|p| p.wall == wall)
        .map(|p| p.s_m)
        .collect();
    s.windows(2).map(|w| w[1] - w[0]).collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8], files: &mut Vec<PathBuf>) -> Result<(), String> {
    let p = dir.join(name);
    std::fs::write(&p, bytes).map_err(|e| format!("{}: {e}", p.display()))?;
    files.push(p);
    Ok(())
}

/// Designs the layout and writes every file into `dir` (which must exist).
pub fn design(req: &DesignRequest, dir: &Path) -> Result<DesignReport, String> {
    let LandmarkChoice::Shape(shape) = req.choice else {
        return Err("a design needs a landmark model (p1…f4), not none".into());
    };
    let tunnel = req.scenario.tunnel_spec().map_err(|e| e.to_string())?;
    let length_m = tunnel.centerline.length_m();
    let placements = layout(req, length_m)?;
    let profile = req.choice.profile();
    let world = World::with_placements(
        &tunnel,
        placements.clone(),
        profile.clone(),
        &mut Pcg32::new(req.scenario.seed, 0x3a11),
    );
    let map = stored_map::build(&world, &req.choice).map_err(|e| {
        format!("the layout does not fit loc-core's stored map: {e} (widen the spacing or shorten the tunnel)")
    })?;
    let mut files = Vec::new();

    // Installation schedule.
    let mut csv =
        String::from("number,wall,chainage_m,spacing_to_previous_m,mounting_height_m,x_m,y_m\n");
    let mut n = 0;
    for wall in [WallSide::Left, WallSide::Right] {
        let mut prev: Option<f64> = None;
        for p in placements.iter().filter(|p| p.wall == wall) {
            n += 1;
            let (x, y) = world.centerline().offset_point(
                p.s_m,
                match wall {
                    WallSide::Left => world.width_m() / 2.0,
                    WallSide::Right => -world.width_m() / 2.0,
                },
            );
            let _ = writeln!(
                csv,
                "{n},{},{:.3},{},{:.3},{x:.3},{y:.3}",
                match wall {
                    WallSide::Left => "left",
                    WallSide::Right => "right",
                },
                p.s_m,
                prev.map_or(String::new(), |q| format!("{:.3}", p.s_m - q)),
                req.mounting_height_m
            );
            prev = Some(p.s_m);
        }
    }
    write(dir, "schedule.csv", csv.as_bytes(), &mut files)?;

    // Cutting template.
    let title = format!(
        "{} W {:.0} mm H {:.0} mm",
        shape.model.code(),
        f64::from(shape.genome.width_m) * 1e3,
        f64::from(shape.genome.height_m) * 1e3
    );
    write(
        dir,
        "template.svg",
        template_svg::template(&title, &profile).as_bytes(),
        &mut files,
    )?;

    // Bill of materials.
    let profile_length_m: f64 = profile
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum();
    let bom = BillOfMaterials {
        count: placements.len(),
        profile_length_m,
        total_profile_length_m: profile_length_m * placements.len() as f64,
        sheet_area_m2: profile_length_m * placements.len() as f64 * req.landmark_depth_m,
    };
    let bom_csv = format!(
        "item,quantity,unit\nlandmarks ({}),{},pieces\nprofile length per landmark,{:.3},m\nprofile length in all,{:.2},m\nsheet ({:.0} mm deep),{:.2},m2\n",
        title, bom.count, bom.profile_length_m, bom.total_profile_length_m, req.landmark_depth_m * 1e3, bom.sheet_area_m2
    );
    write(dir, "bom.csv", bom_csv.as_bytes(), &mut files)?;

    // The map the firmware loads.
    let bytes = stored_map::to_file_bytes(&map).map_err(|e| e.to_string())?;
    write(dir, "map.postcard", &bytes, &mut files)?;

    // Predicted accuracy.
    let points: Vec<AccuracyPoint> = accuracy::along_tunnel(
        &world,
        &map,
        &req.scenario,
        req.scenario.drive.start_m.max(0.0),
        req.scenario.drive.end_m.min(length_m),
        req.step_m,
    );
    let mut acc = String::from("chainage_m,along_sd_m,across_sd_m,curvature_1pm\n");
    for p in &points {
        let _ = writeln!(
            acc,
            "{:.2},{},{},{:.6}",
            p.chainage_m, p.along_sd_m, p.across_sd_m, p.curvature_1pm
        );
    }
    write(dir, "accuracy.csv", acc.as_bytes(), &mut files)?;
    files.extend(
        accuracy::write_plot(dir, &title, &points, req.target_along_m)
            .map_err(|e| e.to_string())?,
    );
    let finite: Vec<f64> = points.iter().map(|p| p.along_sd_m).collect();
    let worst = finite.iter().copied().fold(0.0, f64::max);
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    let (dl, dr) = (
        spacings(&placements, WallSide::Left),
        spacings(&placements, WallSide::Right),
    );
    let per_wall = |w| placements.iter().filter(|p| p.wall == w).count();
    let mut report = DesignReport {
        model: shape.model.code().to_string(),
        genes: req.choice.genes(),
        tunnel_length_m: length_m,
        landmarks_per_wall: (per_wall(WallSide::Left), per_wall(WallSide::Right)),
        shortest_unique_window: (
            spacing::shortest_unique_window(&dl, req.tolerance_m),
            spacing::shortest_unique_window(&dr, req.tolerance_m),
        ),
        spacing_tolerance_m: req.tolerance_m,
        bill_of_materials: bom,
        target_along_m: req.target_along_m,
        worst_along_sd_m: worst,
        mean_along_sd_m: mean,
        stretches_above_target: accuracy::stretches_above(&points, req.target_along_m),
        files: Vec::new(),
    };
    let json_path = dir.join("design.json");
    files.push(json_path.clone());
    report.files = files;
    let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    std::fs::write(&json_path, json).map_err(|e| format!("{}: {e}", json_path.display()))?;
    Ok(report)
}

/// The text report of a design.
pub fn text(r: &DesignReport) -> String {
    let mut t = format!(
        "{} {:?} over {:.0} m: {} landmarks (left {}, right {})\n",
        r.model,
        r.genes,
        r.tunnel_length_m,
        r.bill_of_materials.count,
        r.landmarks_per_wall.0,
        r.landmarks_per_wall.1
    );
    let w = |k: Option<usize>| k.map_or("none".to_string(), |k| k.to_string());
    let _ = writeln!(
        t,
        "shortest window of spacings that identifies every position: left {}, right {} (at {:.0} mm)",
        w(r.shortest_unique_window.0),
        w(r.shortest_unique_window.1),
        r.spacing_tolerance_m * 1e3
    );
    let b = &r.bill_of_materials;
    let _ = writeln!(
        t,
        "bill of materials: {} pieces, {:.3} m of profile each, {:.1} m in all, {:.2} m² of sheet",
        b.count, b.profile_length_m, b.total_profile_length_m, b.sheet_area_m2
    );
    let _ = writeln!(
        t,
        "predicted along-tunnel 1σ per scan: mean {:.2} mm, worst {:.2} mm (target {:.1} mm)",
        r.mean_along_sd_m * 1e3,
        r.worst_along_sd_m * 1e3,
        r.target_along_m * 1e3
    );
    if r.stretches_above_target.is_empty() {
        t += "every chainage meets the target\n";
    } else {
        let _ = writeln!(t, "stretches above the target:");
        for s in &r.stretches_above_target {
            let _ = writeln!(
                t,
                "  {:.0}–{:.0} m: worst {:.1} mm{}",
                s.from_m,
                s.to_m,
                s.worst_along_sd_m * 1e3,
                if s.in_curve { " (in a curve)" } else { "" }
            );
        }
    }
    for f in &r.files {
        let _ = writeln!(t, "wrote {}", f.display());
    }
    t.trim_end().to_string()
}

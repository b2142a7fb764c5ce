//! `export-map --format image`: the flash image the controller queries in place, from a
//! scenario or converted from a map file (a survey's), answering as the map it came from.

use std::process::Command;

use loc_core::geometry::Point2;
use loc_core::map::{MapImage, MapQuery, TunnelMap};

fn host_sim(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn a_map_file_converts_to_an_image_that_answers_as_the_map() {
    let dir = std::env::temp_dir().join(format!("map-image-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("map.postcard");
    let out = host_sim(&[
        "export-map",
        "--scenario",
        "demo-200m",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = host_sim(&[
        "export-map",
        "--map",
        file.to_str().unwrap(),
        "--format",
        "image",
        "--out",
        "-",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = MapImage::from_bytes(&out.stdout).unwrap();
    let mut map = Box::<TunnelMap>::default();
    map.load_from_bytes(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(image.landmark_count(), map.landmarks().len());
    assert_eq!(image.segment_count(), map.segments().len());
    for i in 0..400 {
        let p = Point2::new(i as f32 * 0.5, (i % 7) as f32 - 3.0);
        assert_eq!(image.nearest(p, 4.0), map.nearest(p, 4.0));
        assert_eq!(
            image.raycast(p, i as f32 * 0.1, 60.0),
            map.raycast(p, i as f32 * 0.1, 60.0)
        );
    }
    // An image is not a map file: `--map` says what it got.
    let img = dir.join("map.image");
    std::fs::write(&img, &out.stdout).unwrap();
    let out = host_sim(&[
        "export-map",
        "--map",
        img.to_str().unwrap(),
        "--format",
        "image",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("LCMI"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--config-out`: the scenario's localiser configuration as the controller reads it (with
/// the sweep de-skewed).
#[test]
fn the_configuration_record_is_the_scenarios_localiser_configuration() {
    let dir = std::env::temp_dir().join(format!("config-record-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("config.bin");
    let out = host_sim(&[
        "export-map",
        "--scenario",
        "paper-10m",
        "--out",
        dir.join("map.image").to_str().unwrap(),
        "--format",
        "image",
        "--config-out",
        path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let record = loc_core::localizer::LocalizerConfig::from_record(&std::fs::read(&path).unwrap());
    let scenario = host_sim::scenario::named::named("paper-10m").unwrap();
    let mut expected = host_sim::estimator::localizer_config(&scenario);
    // A vehicle's scanner sweeps, whatever the scenario simulated.
    expected.deskew = true;
    assert_eq!(record, Ok(expected));
    std::fs::remove_dir_all(&dir).ok();
}

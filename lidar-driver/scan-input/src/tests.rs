use super::*;
use lidar_driver::recording::Recording;
use lidar_driver::{ChannelRepr, CommandType, Dialect, Frame, ScanRepr};
use loc_core::geometry::Pose2;

/// Every scan telegram of a capture, as CoLa frames.
fn capture_scans(name: &str) -> Vec<Vec<u8>> {
    let rec = Recording::read_file(sick_captures::path(name)).unwrap();
    rec.frames()
        .frames
        .iter()
        .filter(|f| ScanData::new_checked(f.frame()).is_ok())
        .map(|f| f.frame().as_bytes().to_vec())
        .collect()
}

fn decode(bytes: &[u8]) -> ScanData<'_> {
    ScanData::new_checked(Frame::new_checked(bytes).unwrap()).unwrap()
}

fn sensor() -> SensorSetup {
    SensorSetup {
        geometry: ScanGeometry::lms511(),
        mounting: Pose2::IDENTITY,
    }
}

#[test]
fn real_lms511_scans_step_by_exactly_one_sixth_of_a_degree() {
    let scans = capture_scans(sick_captures::LMS511_S2H);
    assert_eq!(scans.len(), 174);
    let mut scan = Scan::new();
    for bytes in &scans {
        let t = decode(bytes);
        let layout = load_scan(&t, &sensor(), EchoSelection::Last, &mut scan).unwrap();
        assert_eq!(
            (
                layout.start_angle_1e4_deg,
                layout.step_1e4_deg,
                layout.beams
            ),
            (-50_000, 1667, 1141)
        );
        // 25 Hz and 54 kHz in the header: 360° · 25 / 54000 = 1/6°.
        let exact = layout.exact_step_1e4_deg().unwrap();
        assert!((exact - 10_000.0 / 6.0).abs() < 1e-9, "{exact}");
        // The last beam lands on 185°, not 185.04° as the rounded field would put it.
        let last_deg = layout.beam_angle_rad(1140).to_degrees();
        assert!((last_deg - 185.0).abs() < 1e-9, "{last_deg}");
        assert_eq!(usize::from(scan.beams_received()), 1141);
        assert!(scan.len() > 500, "{}", scan.len());
    }
    // Beam angles of the scan are the exact ones (f32).
    let p = scan.points().last().unwrap();
    let exact_rad = (-5.0 + f64::from(p.beam_index) / 6.0).to_radians();
    assert!((f64::from(p.angle_rad) - exact_rad).abs() < 2e-6);
}

#[test]
fn real_lms511_scans_say_when_their_beams_were_taken() {
    // 25 Hz and 54 kHz: one beam every 18.5 µs, the 1141 beams over 21.1 ms, stamped on the
    // scanner's µs clock 40 ms apart.
    let scans = capture_scans(sick_captures::LMS511_S2H);
    let mut scan = Scan::new();
    let mut stamps = Vec::new();
    for bytes in &scans {
        let t = decode(bytes);
        load_scan(&t, &sensor(), EchoSelection::Last, &mut scan).unwrap();
        let timing = scan.timing().unwrap();
        assert_eq!(timing.stamp_us, t.header.time_since_startup_us);
        assert!((timing.beam_period_s - 1.0 / 54_000.0).abs() < 1e-12);
        assert!((scan.sweep_s() - 1140.0 / 54_000.0).abs() < 1e-7);
        stamps.push(timing);
    }
    for w in stamps.windows(2) {
        let dt_s = w[1].seconds_since(&w[0]);
        // Consecutive telegrams of the capture, or a whole number of scans apart.
        let periods = dt_s / 0.04;
        assert!(
            periods >= 0.99 && (periods - periods.round()).abs() < 0.01,
            "{dt_s}"
        );
    }
    // Raw values without a header carry no timing until the caller gives it.
    let layout = BeamLayout::of(
        &decode(&scans[0]).header,
        &decode(&scans[0]).channels16().iter().next().unwrap().header,
    );
    load_values(
        &layout,
        [5000u16; 1141].into_iter(),
        1.0,
        0.0,
        &sensor(),
        &mut scan,
    )
    .unwrap();
    assert!(scan.timing().is_none());
    assert_eq!(layout.timing(7).map(|t| t.stamp_us), Some(7));
}

#[test]
fn real_lms111_and_tim_scans_keep_a_step_their_header_agrees_with() {
    for (name, count, start, step) in [
        (sick_captures::LMS111_S2H, 175, -450_000, 5000),
        (sick_captures::TIM_PCAPNG, 16, -450_000, 3333),
    ] {
        let scans = capture_scans(name);
        assert_eq!(scans.len(), count, "{name}");
        let mut scan = Scan::new();
        for bytes in &scans {
            let t = decode(bytes);
            let layout = match load_scan(&t, &sensor(), EchoSelection::Last, &mut scan) {
                Ok(l) => l,
                Err(ScanInputError::TooManyBeams { .. }) => panic!("{name}: too many beams"),
                Err(e) => panic!("{name}: {e}"),
            };
            assert_eq!(
                (layout.start_angle_1e4_deg, layout.step_1e4_deg),
                (start, step)
            );
            // Whatever the header says, the step used rounds to the telegram's field.
            let used = layout.step_used_1e4_deg();
            assert!((used - f64::from(step)).abs() <= 0.5, "{name}: {used}");
        }
    }
}

/// A synthetic telegram with one DIST1 channel.
fn telegram(values: Vec<u16>, scale: f32, start: i32, step: u16, freqs: (u32, u32)) -> Vec<u8> {
    let first = capture_scans(sick_captures::LMS511_S2H).remove(0);
    let t = decode(&first);
    let mut repr = ScanRepr::parse(&t);
    repr.command_type = CommandType::Event;
    repr.header.scan_frequency_1e2_hz = freqs.0;
    repr.header.measurement_frequency_100hz = freqs.1;
    repr.channels8.clear();
    repr.channels16 = vec![ChannelRepr {
        name: *b"DIST1",
        scale_factor: scale,
        scale_offset: 0.0,
        start_angle_1e4_deg: start,
        step_1e4_deg: step,
        values,
    }];
    repr.to_vec(Dialect::ColaB).unwrap()
}

#[test]
fn another_start_angle_and_step_are_taken_from_the_telegram() {
    // 50 Hz at 1/3°, starting at +10°: 541 beams to 190°.
    let bytes = telegram(vec![2000; 541], 1.0, 100_000, 3333, (5000, 540));
    let mut scan = Scan::new();
    let layout = load_scan(&decode(&bytes), &sensor(), EchoSelection::Last, &mut scan).unwrap();
    assert_eq!(layout.beams, 541);
    assert!((layout.step_used_1e4_deg() - 10_000.0 / 3.0).abs() < 1e-9);
    let last = scan.points().last().unwrap();
    assert!((f64::from(last.angle_rad).to_degrees() - 190.0).abs() < 1e-4);
    assert!((scan.points()[0].angle_rad.to_degrees() - 10.0).abs() < 1e-5);
}

#[test]
fn a_header_that_disagrees_with_the_channel_is_not_trusted() {
    // 35 Hz at 0.25° would need 50.4 kHz; a header saying 54 kHz gives 0.2333°, which does
    // not round to 2500: the channel's own step is used.
    let bytes = telegram(vec![2000; 761], 1.0, -50_000, 2500, (3500, 540));
    let layout = load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::Last,
        &mut Scan::new(),
    )
    .unwrap();
    assert_eq!(layout.exact_step_1e4_deg(), None);
    assert_eq!(layout.step_used_1e4_deg(), 2500.0);
    // Unknown frequencies (0): the field.
    let none = BeamLayout {
        scan_frequency_1e2_hz: 0,
        ..layout
    };
    assert_eq!(none.step_used_1e4_deg(), 2500.0);
}

#[test]
fn scale_two_encodes_long_ranges_and_saturation_is_no_range() {
    // 70 m at scale 2 is raw 35000; 0xFFFF is saturated, 0 no echo.
    let bytes = telegram(vec![35_000, u16::MAX, 0, 1000], 2.0, 0, 10_000, (2500, 540));
    let mut scan = Scan::new();
    load_scan(&decode(&bytes), &sensor(), EchoSelection::Last, &mut scan).unwrap();
    assert_eq!(scan.len(), 2);
    assert!((scan.points()[0].range_m - 70.0).abs() < 1e-4);
    assert!((scan.points()[1].range_m - 2.0).abs() < 1e-6);
    let d = scan.dropped();
    assert_eq!((d.saturated, d.no_echo), (1, 1));
}

#[test]
fn too_many_beams_and_no_distance_channel_are_refused() {
    let bytes = telegram(vec![1000; 1142], 1.0, -50_000, 1667, (2500, 540));
    assert_eq!(
        load_scan(
            &decode(&bytes),
            &sensor(),
            EchoSelection::Last,
            &mut Scan::new()
        ),
        Err(ScanInputError::TooManyBeams { beams: 1142 })
    );
    let first = capture_scans(sick_captures::LMS511_S2H).remove(0);
    let mut repr = ScanRepr::parse(&decode(&first));
    repr.channels16.clear();
    let bytes = repr.to_vec(Dialect::ColaB).unwrap();
    let e = load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::Last,
        &mut Scan::new(),
    )
    .unwrap_err();
    assert_eq!(e, ScanInputError::NoDistanceChannel);
    assert!(e.to_string().contains("LMDscandatacfg"));
}

proptest::proptest! {
    #[test]
    fn any_layout_numbers_give_a_step_that_rounds_to_the_field(
        start in proptest::prelude::any::<i32>(),
        step in proptest::prelude::any::<u16>(),
        beams in proptest::prelude::any::<u16>(),
        f_scan in proptest::prelude::any::<u32>(),
        f_shot in proptest::prelude::any::<u32>(),
    ) {
        let l = BeamLayout {
            start_angle_1e4_deg: start,
            step_1e4_deg: step,
            beams,
            scan_frequency_1e2_hz: f_scan,
            measurement_frequency_100hz: f_shot,
        };
        let used = l.step_used_1e4_deg();
        proptest::prop_assert!(used.is_finite());
        proptest::prop_assert!((used - f64::from(step)).abs() <= 0.5);
        let g = l.geometry(0.7, 80.0);
        proptest::prop_assert!(g.start_angle_rad.is_finite() && g.step_rad.is_finite());
        let values = vec![1234u16; usize::from(beams).min(2000)];
        let r = load_values(&l, values.iter().copied(), 1.0, 0.0, &sensor(), &mut Scan::new());
        proptest::prop_assert_eq!(r.is_ok(), usize::from(beams) <= LMS511_MAX_BEAMS && values.len() <= LMS511_MAX_BEAMS);
    }
}

/// A telegram with the distance channels `channels` (name, values) at the LMS511's layout,
/// in `dialect`.
fn echo_telegram(channels: &[([u8; 5], Vec<u16>)], dialect: Dialect) -> Vec<u8> {
    let first = capture_scans(sick_captures::LMS511_S2H).remove(0);
    let mut repr = ScanRepr::parse(&decode(&first));
    repr.command_type = CommandType::Event;
    repr.channels8.clear();
    repr.channels16 = channels
        .iter()
        .map(|(name, values)| ChannelRepr {
            name: *name,
            scale_factor: 1.0,
            scale_offset: 0.0,
            start_angle_1e4_deg: -50_000,
            step_1e4_deg: 1667,
            values: values.clone(),
        })
        .collect();
    repr.to_vec(dialect).unwrap()
}

/// Beam index → range (m) of the points a scan kept.
fn ranges_by_beam(scan: &Scan) -> Vec<(u16, f32)> {
    scan.points()
        .iter()
        .map(|p| (p.beam_index, p.range_m))
        .collect()
}

/// Beam index and millimetres as [`ranges_by_beam`] gives them.
fn mm(points: &[(u16, u16)]) -> Vec<(u16, f32)> {
    points
        .iter()
        .map(|&(i, v)| (i, f32::from(v) * 0.001))
        .collect()
}

/// The reference choice: the beam's echoes in channel order, 0 = none.
fn reference(echoes: &[u16], selection: EchoSelection) -> u16 {
    match selection {
        EchoSelection::First => echoes.first().copied().unwrap_or(0),
        EchoSelection::Last => echoes.iter().rev().find(|&&v| v != 0).copied().unwrap_or(0),
    }
}

#[test]
fn the_last_echo_sees_through_dust_and_the_first_takes_it() {
    // Beam 0: dust at 1.5 m, wall at 4 m; beam 1: wall only; beam 2: dust alone (blocked);
    // beam 3: no echo; beam 4: three echoes.
    let dist1 = vec![1500, 4000, 1200, 0, 1000];
    let dist2 = vec![4000, 0, 0, 0, 2500];
    let dist3 = vec![0, 0, 0, 0, 6000];
    let dist = |n: u8, v: &Vec<u16>| {
        let mut d = v.clone();
        d.resize(5, 0);
        (*b"DIST0", d, n)
    };
    let chans: Vec<([u8; 5], Vec<u16>)> = [dist(1, &dist1), dist(2, &dist2), dist(3, &dist3)]
        .into_iter()
        .map(|(mut name, d, n)| {
            name[4] = b'0' + n;
            (name, d)
        })
        .collect();
    for dialect in [Dialect::ColaB, Dialect::ColaA] {
        let bytes = echo_telegram(&chans, dialect);
        let mut scan = Scan::new();
        load_scan(&decode(&bytes), &sensor(), EchoSelection::Last, &mut scan).unwrap();
        assert_eq!(
            ranges_by_beam(&scan),
            mm(&[(0, 4000), (1, 4000), (2, 1200), (4, 6000)]),
            "{dialect:?}"
        );
        load_scan(&decode(&bytes), &sensor(), EchoSelection::First, &mut scan).unwrap();
        assert_eq!(
            ranges_by_beam(&scan),
            mm(&[(0, 1500), (1, 4000), (2, 1200), (4, 1000)])
        );
    }
    // Channels in any order land by their number; the default is the last echo.
    let reversed: Vec<_> = chans.iter().rev().cloned().collect();
    let mut scan = Scan::new();
    let bytes = echo_telegram(&reversed, Dialect::ColaB);
    load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::default(),
        &mut scan,
    )
    .unwrap();
    assert_eq!(
        ranges_by_beam(&scan),
        mm(&[(0, 4000), (1, 4000), (2, 1200), (4, 6000)])
    );
}

#[test]
fn an_echo_channel_of_other_beams_is_refused_and_dist1_is_needed() {
    let first = capture_scans(sick_captures::LMS511_S2H).remove(0);
    let mut repr = ScanRepr::parse(&decode(&first));
    let mut dist2 = repr.channels16[0].clone();
    dist2.name = *b"DIST2";
    dist2.step_1e4_deg = 3333;
    repr.channels16.push(dist2.clone());
    let bytes = repr.to_vec(Dialect::ColaB).unwrap();
    let e = load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::Last,
        &mut Scan::new(),
    );
    assert_eq!(e, Err(ScanInputError::EchoChannelMismatch { echo: 2 }));
    assert!(e.unwrap_err().to_string().contains("DIST2"));
    // A scale of its own is refused too (the values would be read at DIST1's).
    repr.channels16[1] = ChannelRepr {
        step_1e4_deg: 1667,
        scale_factor: 2.0,
        ..dist2
    };
    let bytes = repr.to_vec(Dialect::ColaB).unwrap();
    let e = load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::First,
        &mut Scan::new(),
    );
    assert_eq!(e, Err(ScanInputError::EchoChannelMismatch { echo: 2 }));
    // DIST2 without DIST1: no distance channel to take the layout from.
    repr.channels16.remove(0);
    let bytes = repr.to_vec(Dialect::ColaB).unwrap();
    let e = load_scan(
        &decode(&bytes),
        &sensor(),
        EchoSelection::Last,
        &mut Scan::new(),
    );
    assert_eq!(e, Err(ScanInputError::NoDistanceChannel));
}

#[test]
fn selected_echoes_step_every_channel_and_read_short_ones_as_none() {
    let a = [1000u16, 2000, 0];
    let b = [3000u16];
    let channels = [
        Some(a.iter().copied()),
        Some(b.iter().copied()),
        None,
        None,
        None,
    ];
    let last: Vec<u16> = SelectedEchoes::new(channels.clone(), 3, EchoSelection::Last).collect();
    assert_eq!(last, [3000, 2000, 0]);
    let first = SelectedEchoes::new(channels, 3, EchoSelection::First);
    assert_eq!(first.len(), 3);
    assert_eq!(first.collect::<Vec<_>>(), [1000, 2000, 0]);
    let none: [Option<std::array::IntoIter<u16, 0>>; MAX_ECHOES] = Default::default();
    assert_eq!(
        SelectedEchoes::new(none, 2, EchoSelection::Last).collect::<Vec<_>>(),
        [0, 0]
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Any beams with up to five echoes in range order, written as DIST1…DISTn in either
    /// dialect, parsed by lidar-driver and loaded: each beam's point is the chosen echo.
    #[test]
    fn multi_echo_telegrams_round_trip_to_the_chosen_echo(
        beams in proptest::collection::vec(
            proptest::collection::vec(800u16..60_000, 0..=MAX_ECHOES), 1..200),
        channels in 1usize..=MAX_ECHOES,
        colab in proptest::prelude::any::<bool>(),
    ) {
        // Echoes of a beam in range order, at most `channels` of them.
        let beams: Vec<Vec<u16>> = beams
            .into_iter()
            .map(|mut e| { e.sort_unstable(); e.truncate(channels); e })
            .collect();
        let chans: Vec<([u8; 5], Vec<u16>)> = (0..channels)
            .map(|k| {
                let mut name = *b"DIST1";
                name[4] = b'1' + k as u8;
                (name, beams.iter().map(|e| e.get(k).copied().unwrap_or(0)).collect())
            })
            .collect();
        let dialect = if colab { Dialect::ColaB } else { Dialect::ColaA };
        let bytes = echo_telegram(&chans, dialect);
        for selection in [EchoSelection::First, EchoSelection::Last] {
            let mut scan = Scan::new();
            let layout = load_scan(&decode(&bytes), &sensor(), selection, &mut scan).unwrap();
            proptest::prop_assert_eq!(usize::from(layout.beams), beams.len());
            let expected: Vec<(u16, f32)> = beams
                .iter()
                .enumerate()
                .filter_map(|(i, e)| {
                    let v = reference(e, selection);
                    (v != 0).then(|| (i as u16, f32::from(v) * 0.001))
                })
                .collect();
            proptest::prop_assert_eq!(ranges_by_beam(&scan), expected);
        }
    }

    /// The iterator agrees with the reference on any values, zeros anywhere included.
    #[test]
    fn selected_echoes_agree_with_the_reference(
        values in proptest::collection::vec(
            proptest::collection::vec(0u16..4, MAX_ECHOES), 0..50),
    ) {
        for selection in [EchoSelection::First, EchoSelection::Last] {
            let mut columns = (0..MAX_ECHOES)
                .map(|k| Some(values.iter().map(move |b| b[k]).collect::<Vec<_>>().into_iter()));
            let channels = std::array::from_fn(|_| columns.next().flatten());
            let got: Vec<u16> = SelectedEchoes::new(channels, values.len(), selection).collect();
            let want: Vec<u16> = values.iter().map(|b| reference(b, selection)).collect();
            proptest::prop_assert_eq!(got, want);
        }
    }
}

//! Occupancy grid and its ROS map_server export: walls where they are, growth, round trips.

use sketchslam_engine::mapping::grid::{GridConfig, OccupancyGrid};
use sketchslam_engine::mapping::ros_export::{occupied_points_from_map, parse_map_yaml, parse_pgm};
use sketchslam_types::{Point2, Pose2, Scan, ScanHeader};

/// Half side of the square room, meters: walls at x = ±H and y = ±H.
const H: f64 = 4.0;

/// Range from `pose` along world angle `a` to the square room's walls (analytic ray cast).
fn room_range(pose: &Pose2, a: f64) -> f64 {
    let (s, c) = a.sin_cos();
    let mut best = f64::INFINITY;
    for (d, o) in [(c, pose.x), (s, pose.y)] {
        if d.abs() > 1e-12 {
            for wall in [-H, H] {
                let t = (wall - o) / d;
                if t > 0.0 {
                    best = best.min(t);
                }
            }
        }
    }
    best
}

fn room_scan(pose: &Pose2) -> Scan {
    let beams = 1081;
    let fov = 270f64.to_radians();
    let inc = fov / (beams - 1) as f64;
    let angle_min = -fov / 2.0;
    let ranges_m = (0..beams)
        .map(|i| room_range(pose, pose.heading_rad + angle_min + i as f64 * inc) as f32)
        .collect();
    Scan::centred(fov, 0.05, 30.0, ranges_m)
}

fn room_grid() -> OccupancyGrid {
    let mut g = OccupancyGrid::new(GridConfig::default());
    let poses = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(1.5, -1.0, 2.0),
        Pose2::new(-2.0, 2.0, -1.0),
        Pose2::new(-1.0, -2.5, 3.0),
        Pose2::new(2.5, 2.5, -2.5),
    ];
    for _ in 0..3 {
        for p in &poses {
            g.insert_scan(p, &room_scan(p));
        }
    }
    g
}

#[test]
fn square_room_walls_are_where_they_are() {
    let g = room_grid();
    let occ = g.occupied_points();
    assert!(occ.len() > 400, "only {} occupied cells", occ.len());
    let r = g.resolution_m();
    for p in &occ {
        let d = (p.x.abs() - H).abs().min((p.y.abs() - H).abs());
        let inside = p.x.abs() <= H + r && p.y.abs() <= H + r;
        assert!(d <= r && inside, "occupied cell at {p:?} is off the walls");
    }
    // Every wall is seen along most of its length.
    for (sx, sy) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
        let n = occ
            .iter()
            .filter(|p| {
                if sx != 0.0 {
                    (p.x - sx * H).abs() <= r
                } else {
                    (p.y - sy * H).abs() <= r
                }
            })
            .count();
        assert!(
            n as f64 > 0.8 * 2.0 * H / r,
            "wall ({sx}, {sy}) has only {n} cells"
        );
    }
    // The interior (away from the walls) is free.
    let mut checked = 0;
    let mut y = -H + 0.3;
    while y < H - 0.3 {
        let mut x = -H + 0.3;
        while x < H - 0.3 {
            let (c, rw) = g.cell_of(Point2::new(x, y)).unwrap();
            assert!(
                !g.is_occupied(c, rw),
                "interior cell at ({x}, {y}) occupied"
            );
            assert!(g.is_free(c, rw), "interior cell at ({x}, {y}) not free");
            checked += 1;
            x += 0.25;
        }
        y += 0.25;
    }
    assert!(checked > 500);
    // Outside the room: unknown.
    let (c, rw) = g.cell_of(Point2::new(H + 0.5, 0.0)).unwrap();
    assert!(g.is_unknown(c, rw));
}

#[test]
fn growth_keeps_earlier_content() {
    let mut g = OccupancyGrid::new(GridConfig::default());
    let p0 = Pose2::new(0.0, 0.0, 0.0);
    g.insert_scan(&p0, &room_scan(&p0));
    let before: Vec<Point2> = g.occupied_points();
    let (w0, h0) = (g.width(), g.height());
    // A far-away scan (the same room shifted by 40 m in x and −25 m in y, in world terms a
    // different room) forces the grid to grow to the right and down.
    let far = Pose2::new(40.0, -25.0, 0.5);
    let s = room_scan(&Pose2::new(0.0, 0.0, 0.5));
    g.insert_scan(&far, &s);
    assert!(g.width() > w0 && g.height() > h0);
    let o = g.origin();
    assert!(o.y < -25.0 - H);
    let r = g.resolution_m();
    assert!(
        (o.x / r - (o.x / r).round()).abs() < 1e-9,
        "origin not on the cell lattice"
    );
    for p in &before {
        let (c, rw) = g.cell_of(*p).unwrap();
        assert!(g.is_occupied(c, rw), "lost occupied cell at {p:?}");
        let q = g.cell_center(c, rw);
        assert!(q.distance(p) < 1e-9);
    }
    assert!(g.occupied_points().len() > before.len());
    // Growing to the left and up as well.
    g.insert_scan(&Pose2::new(-30.0, 30.0, 0.0), &room_scan(&p0));
    for p in &before {
        let (c, rw) = g.cell_of(*p).unwrap();
        assert!(g.is_occupied(c, rw));
    }
}

#[test]
fn pgm_yaml_round_trip_gives_the_same_occupied_points() {
    let g = room_grid();
    let pgm = g.to_pgm();
    let yaml = g.to_yaml("map.pgm");
    let meta = parse_map_yaml(&yaml).unwrap();
    assert_eq!(meta.image, "map.pgm");
    assert_eq!(meta.resolution_m, g.resolution_m());
    assert_eq!(meta.origin.x, g.origin().x);
    assert_eq!(meta.origin.y, g.origin().y);
    assert!(!meta.negate);
    assert_eq!(meta.occupied_thresh, 0.65);
    assert_eq!(meta.free_thresh, 0.196);
    let (w, h, px) = parse_pgm(&pgm).unwrap();
    assert_eq!((w, h), (g.width(), g.height()));
    let back = occupied_points_from_map(&meta, w, h, &px);
    assert_eq!(back, g.occupied_points());
    // The PNG is the same picture.
    let png = image::load_from_memory(&g.to_png()).unwrap().to_luma8();
    assert_eq!((png.width() as usize, png.height() as usize), (w, h));
    assert_eq!(png.into_raw(), px);
    // JSON occupancy agrees too: bottom row first, ≥ 65 exactly when occupied.
    let ros = g.to_ros_occupancy();
    assert_eq!(ros.data.len(), w * h);
    for row in 0..h {
        for col in 0..w {
            let v = ros.data[row * w + col];
            assert_eq!(v >= 65, g.is_occupied(col, row));
            assert_eq!(v == -1, g.is_unknown(col, row));
            let img = px[(h - 1 - row) * w + col];
            assert_eq!(img == 0, v >= 65);
            assert_eq!(img == 254, (0..=19).contains(&v));
        }
    }
}

#[test]
fn pgm_header_bytes_and_unknown_value() {
    let g = OccupancyGrid::new(GridConfig::default());
    let pgm = g.to_pgm();
    let header = format!(
        "P5\n# CREATOR: sketchslam 0.050 m/pix\n{} {}\n255\n",
        g.width(),
        g.height()
    );
    assert!(pgm.starts_with(header.as_bytes()));
    assert_eq!(pgm.len(), header.len() + g.width() * g.height());
    assert!(pgm[header.len()..].iter().all(|&b| b == 205));
    assert!(g.to_ros_occupancy().data.iter().all(|&v| v == -1));
    let yaml = g.to_yaml("map.pgm");
    assert_eq!(
        yaml,
        format!(
            "image: map.pgm\nresolution: 0.05\norigin: [{:?}, {:?}, 0.0]\nnegate: 0\n\
             occupied_thresh: 0.65\nfree_thresh: 0.196\n",
            g.origin().x,
            g.origin().y
        )
    );
}

#[test]
fn tiny_pgm_exact_layout() {
    // One beam straight up from the cell (0,0) corner region: hit 2 cells above.
    let mut g = OccupancyGrid::new(GridConfig::default());
    let scan = Scan {
        header: ScanHeader {
            angle_min_rad: std::f32::consts::FRAC_PI_2,
            angle_increment_rad: 0.0,
            range_min_m: 0.01,
            range_max_m: 10.0,
            beam_count: 1,
            ..Default::default()
        },
        ranges_m: vec![0.1],
    };
    let pose = Pose2::new(0.025, 0.025, 0.0);
    for _ in 0..3 {
        g.insert_scan(&pose, &scan);
    }
    let (c, r) = g.cell_of(Point2::new(0.025, 0.125)).unwrap();
    assert!(g.is_occupied(c, r));
    let (w, h) = (g.width(), g.height());
    let pgm = g.to_pgm();
    let (pw, ph, px) = parse_pgm(&pgm).unwrap();
    assert_eq!((pw, ph), (w, h));
    // Top row of the image is the top of the map.
    assert_eq!(px[(h - 1 - r) * w + c], 0);
    assert_eq!(px[(h - 1 - (r - 1)) * w + c], 254);
    assert_eq!(px[(h - 1 - (r - 2)) * w + c], 254);
    assert_eq!(px[(h - 1 - (r + 1)) * w + c], 205);
    assert_eq!(px.iter().filter(|&&v| v != 205).count(), 3);
}

#[test]
fn parsers_refuse_garbage() {
    assert!(parse_pgm(b"").is_err());
    assert!(parse_pgm(b"P6\n1 1\n255\n\0\0\0").is_err());
    assert!(parse_pgm(b"P5\n2 2\n255\n\0").is_err());
    assert!(parse_pgm(b"P5\n99999999 99999999\n255\n").is_err());
    assert_eq!(
        parse_pgm(b"P2\n# c\n2 1\n15\n0 15\n").unwrap(),
        (2, 1, vec![0, 255])
    );
    assert!(parse_map_yaml("image: a.pgm\nresolution: nan\norigin: [0, 0, 0]\n").is_err());
    assert!(parse_map_yaml("image: a.pgm\nresolution: 0.05\n").is_err());
    assert!(parse_map_yaml("image: a.pgm\nresolution: 0.05\norigin: [0, 0]\n").is_err());
    let m = parse_map_yaml(
        "# saved\nimage: a.pgm\nresolution: 0.1 # m\norigin: [-1.5, 2.0, 0.0]\nnegate: 1\nmode: trinary\n",
    )
    .unwrap();
    assert!(m.negate && m.resolution_m == 0.1 && m.origin.x == -1.5);
}

#[test]
fn bad_config_falls_back_to_defaults() {
    let g = OccupancyGrid::new(GridConfig {
        resolution_m: f64::NAN,
        log_odds_occupied: -1.0,
        ..GridConfig::default()
    });
    assert_eq!(g.resolution_m(), 0.05);
    assert_eq!(
        g.config().log_odds_occupied,
        GridConfig::default().log_odds_occupied
    );
}

#[test]
fn occupied_points_in_box_is_a_filter_of_all() {
    let g = room_grid();
    let all = g.occupied_points();
    let (min, max) = (Point2::new(-4.02, -1.0), Point2::new(0.5, 4.5));
    let want: Vec<Point2> = all
        .iter()
        .copied()
        .filter(|p| p.x >= min.x && p.x <= max.x && p.y >= min.y && p.y <= max.y)
        .collect();
    assert!(!want.is_empty());
    assert_eq!(g.occupied_points_in_box(min, max), want);
    let everything = g.occupied_points_in_box(Point2::new(-1e6, -1e6), Point2::new(1e6, 1e6));
    assert_eq!(everything, all);
    assert!(g.occupied_points_in_box(max, min).is_empty());
    let nan = Point2::new(f64::NAN, 0.0);
    assert!(g.occupied_points_in_box(nan, max).is_empty());
}

//! Tests of the figures: pixel counts of known colours, errors, text layout, depth order.

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::format::{fmt_num, fmt_tick};
use crate::render::{de, draw_rgb};
use crate::style::*;
use crate::text::{ensure_font, Canvas};
use crate::trajectory::prims::{paint_order, Prim, Projector};
use crate::trajectory::top::equal_aspect;
use crate::*;

/// A fresh, empty directory under the system temp dir.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clothopt-plot-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Width, height and RGB(A) pixels of a PNG file.
fn decode(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let file = std::fs::File::open(path).expect("png exists");
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png frame");
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks(step)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
}

/// Draws `fig`'s 3-D view to `path` if it is named `3d.png`, else its top view.
fn draw_view(fig: &TrajectoryFigure, path: &Path) {
    if path.ends_with("3d.png") {
        draw_trajectory_3d(fig, path).expect("3-D view");
    } else {
        draw_trajectory_top(fig, path).expect("top view");
    }
}

fn count(px: &[[u8; 3]], c: RGBColor) -> usize {
    px.iter().filter(|p| **p == [c.0, c.1, c.2]).count()
}

fn sheet(y: f64) -> Vec<[f64; 3]> {
    (0..9)
        .map(|p| [(p % 3) as f64 * 0.5 - 0.5, y, 2.0 - (p / 3) as f64 * 0.5])
        .collect()
}

#[test]
fn trajectory_views_draw_every_element() {
    let dir = scratch("traj");
    let (a, b) = (sheet(-1.0), sheet(1.0));
    let spheres = [Sphere {
        center: [0.0, 0.0, 1.0],
        radius: 0.3,
    }];
    let targets = [[-0.5, 1.2, 1.0], [0.5, 1.2, 1.0]];
    let fig = TrajectoryFigure {
        title: "test".into(),
        grid: (3, 3),
        frames: vec![(&a[..], "initial".into()), (&b[..], "final".into())],
        control_paths: vec![vec![a[0], [-0.5, 0.0, 2.5], b[0]], vec![a[2], b[2]]],
        spheres: &spheres,
        targets: &targets,
        target_particles: &[6, 8],
        ground_z: Some(0.0),
        safety_margin: Some(0.1),
        ..Default::default()
    };
    for (name, size) in [("3d.png", SIZE_3D), ("top.png", SIZE_2D)] {
        let path = dir.join(name);
        draw_view(&fig, &path);
        let (w, h, px) = decode(&path);
        assert_eq!((w, h), size, "{name}");
        // Markers and solid fills are drawn without anti-aliasing, so exact colours are found.
        assert!(count(&px, PATH_COLORS[0]) > 100, "{name}: purple path");
        assert!(count(&px, PATH_COLORS[1]) > 100, "{name}: green path");
        assert!(count(&px, TARGET_RED) > 30, "{name}: targets");
        assert!(count(&px, FRAME_COLORS[0]) > 20, "{name}: first frame");
        assert!(count(&px, MARGIN_RED) > 20, "{name}: safety margin");
        assert!(count(&px, RGBColor(105, 110, 125)) > 50, "{name}: sphere");
    }
    let panels = [fig.clone(), fig.clone(), fig];
    let path = dir.join("panels.png");
    draw_trajectory_panels("three", &panels, 2, &path).expect("panels");
    let (w, h, px) = decode(&path);
    assert_eq!((w, h), (2 * 460 + 250, 2 * 440 + 50));
    assert!(count(&px, PATH_COLORS[0]) > 300, "three purple paths");
    assert!(matches!(
        draw_trajectory_panels("none", &[], 2, &path),
        Err(PlotError::InvalidData(_))
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bar_chart_and_xy_write_pngs() {
    let dir = scratch("charts");
    let mut bars = BarChart {
        title: "bars".into(),
        y_label: "cost".into(),
        groups: vec![
            ("G".into(), vec![0.0, 1.0, 2.0]),
            ("G+αT".into(), vec![0.5, 0.1, 3.0]),
        ],
        series_names: vec!["G".into(), "αT".into(), "βE".into()],
        pad: 0.1,
        log_y: false,
    };
    for log_y in [false, true] {
        bars.log_y = log_y;
        let path = dir.join(format!("bars_{log_y}.png"));
        draw_bar_chart(&bars, &path).expect("bar chart");
        let (w, h, px) = decode(&path);
        assert_eq!((w, h), SIZE_2D);
        for c in &BAR_COLORS[..3] {
            assert!(count(&px, *c) > 200, "bar colour {c:?} (log {log_y})");
        }
    }
    let fig = XyFigure {
        title: "xy".into(),
        x_label: "time [ms]".into(),
        y_label: "error".into(),
        series: vec![Series {
            name: "a".into(),
            points: vec![(1.0, 1.0), (10.0, 0.1), (100.0, 0.001)],
            labels: vec!["n=1".into(), String::new(), "n=100".into()],
        }],
        log_x: true,
        log_y: true,
        ref_lines: vec![RefLine {
            y: 0.01,
            label: "1 %".into(),
        }],
    };
    let path = dir.join("xy.png");
    draw_xy(&fig, &path).expect("xy plot");
    let (_, _, px) = decode(&path);
    assert!(count(&px, SERIES_COLORS[0]) > 100);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_data_and_bad_paths_are_errors_not_panics() {
    let dir = scratch("errors");
    let a = sheet(0.0);
    let fig = TrajectoryFigure {
        grid: (3, 4),
        frames: vec![(&a[..], "initial".into())],
        ..Default::default()
    };
    let e = draw_trajectory_3d(&fig, &dir.join("x.png")).unwrap_err();
    assert!(
        matches!(&e, PlotError::InvalidData(m) if m.contains("3×4") && m.contains("9 particles")),
        "{e}"
    );
    assert!(matches!(
        draw_trajectory_top(&TrajectoryFigure::default(), &dir.join("x.png")),
        Err(PlotError::InvalidData(_))
    ));

    let mut xy = XyFigure {
        series: vec![Series {
            name: "s".into(),
            points: vec![(1.0, 0.0), (2.0, 1.0)],
            labels: Vec::new(),
        }],
        log_y: true,
        ..Default::default()
    };
    let e = draw_xy(&xy, &dir.join("x.png")).unwrap_err();
    assert!(
        matches!(&e, PlotError::InvalidData(m) if m.contains("y = 0")),
        "{e}"
    );
    xy.log_y = false;
    xy.series[0].labels = vec!["only one".into()];
    assert!(matches!(
        draw_xy(&xy, &dir.join("x.png")),
        Err(PlotError::InvalidData(_))
    ));
    xy.series[0].labels.clear();
    xy.series[0].points[1].1 = f64::NAN;
    assert!(matches!(
        draw_xy(&xy, &dir.join("x.png")),
        Err(PlotError::InvalidData(_))
    ));

    let bars = BarChart {
        title: String::new(),
        y_label: String::new(),
        groups: vec![("G".into(), vec![1.0])],
        series_names: vec!["G".into(), "αT".into()],
        pad: 0.1,
        log_y: false,
    };
    let e = draw_bar_chart(&bars, &dir.join("x.png")).unwrap_err();
    assert!(
        matches!(&e, PlotError::InvalidData(m) if m.contains("1 values")),
        "{e}"
    );

    // I/O problems surface as `Write` errors naming the file.
    xy.series[0].points[1].1 = 1.0;
    let missing = dir.join("no-such-dir").join("x.png");
    let e = draw_xy(&xy, &missing).unwrap_err();
    assert!(
        matches!(&e, PlotError::Write { path, .. } if *path == missing),
        "{e}"
    );
    let e = draw_xy(&xy, &dir.join("x.jpg")).unwrap_err();
    assert!(matches!(e, PlotError::Write { .. }), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn text_is_rendered_with_the_embedded_font_and_anchored() {
    ensure_font().expect("font");
    let (w, h) = (200u32, 100u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = Canvas {
            inner: BitMapBackend::with_buffer(&mut buf, (w, h)),
        }
        .into_drawing_area();
        root.draw(&Text::new(
            "Hxy 0.1".to_string(),
            (100, 50),
            text(20.0).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .expect("text");
        root.present().expect("present");
    }
    let dark: Vec<(u32, u32)> = (0..w * h)
        .filter(|&i| buf[(i * 3) as usize] < 128)
        .map(|i| (i % w, i / w))
        .collect();
    assert!(dark.len() > 60, "text drawn: {} dark pixels", dark.len());
    let (x0, x1) = (
        dark.iter().map(|p| p.0).min().unwrap_or(0),
        dark.iter().map(|p| p.0).max().unwrap_or(0),
    );
    // Horizontally centred on x = 100 within 2 px.
    assert!(
        (x0 as i32 + x1 as i32 - 200).abs() <= 4,
        "x from {x0} to {x1}"
    );
    // Capitals are centred on y = 50: the 'H' stem spans rows symmetric about 50.
    let h_rows: Vec<u32> = dark.iter().filter(|p| p.0 <= x0 + 1).map(|p| p.1).collect();
    let (top, bottom) = (
        h_rows.iter().min().copied().unwrap_or(0),
        h_rows.iter().max().copied().unwrap_or(0),
    );
    assert!(
        (top as i32 + bottom as i32 - 100).abs() <= 2,
        "H from {top} to {bottom}"
    );
}

struct Flat;
impl Projector for Flat {
    fn px(&self, p: [f64; 3]) -> (i32, i32) {
        (p[0] as i32, p[1] as i32)
    }
    fn depth(&self, p: [f64; 3]) -> f64 {
        -p[2]
    }
    fn px_per_unit(&self) -> f64 {
        1.0
    }
}

#[test]
fn higher_elements_are_painted_over_lower_ones() {
    let prims = vec![
        Prim::Marker([0.0, 0.0, 2.0], BLACK, 3),
        Prim::Ball(Sphere {
            center: [0.0, 0.0, 0.0],
            radius: 1.0,
        }),
        Prim::Segment([0.0; 3], [0.0, 0.0, 1.0], BLACK, 1),
    ];
    let order: Vec<&str> = paint_order(&Flat, prims)
        .iter()
        .map(|p| match p {
            Prim::Ball(_) => "ball",
            Prim::Segment(..) => "segment",
            Prim::Marker(..) => "marker",
            Prim::Quad(..) => "quad",
            Prim::Tri(..) => "triangle",
        })
        .collect();
    assert_eq!(order, ["ball", "segment", "marker"]);
}

/// Pixels of the first frame's colour in the plot area of a 3-D view of a 3×3 sheet (plane
/// `y = 1`, `x` from −0.5 to 0.5, `z` from 1 to 2) and a sphere of radius 0.9 on the line of
/// sight through the sheet's centre, `toward_camera` in front of it (negative: behind it).
fn frame_pixels_with_sphere(toward_camera: f64, name: &str) -> usize {
    let dir = scratch(name);
    let sheet = sheet(1.0);
    let view = View3d::default();
    // Unit vector from the scene towards the camera (see `View3d`).
    let eye = [
        view.yaw.sin() * view.pitch.cos(),
        -view.yaw.cos() * view.pitch.cos(),
        view.pitch.sin(),
    ];
    let centre = [0.0, 1.0, 1.5];
    let spheres = [Sphere {
        center: std::array::from_fn(|k| centre[k] + toward_camera * eye[k]),
        radius: 0.9,
    }];
    let fig = TrajectoryFigure {
        title: "wall".into(),
        grid: (3, 3),
        frames: vec![(&sheet[..], "start".into())],
        spheres: &spheres,
        ..Default::default()
    };
    let path = dir.join("wall.png");
    draw_trajectory_3d(&fig, &path).expect("3-D view");
    let (w, _, px) = decode(&path);
    let _ = std::fs::remove_dir_all(&dir);
    // The plot area only: the legend column (250 px on the right) has its own swatch.
    px.chunks(w as usize)
        .flat_map(|row| &row[..w as usize - 250])
        .filter(|p| **p == [FRAME_COLORS[0].0, FRAME_COLORS[0].1, FRAME_COLORS[0].2])
        .count()
}

#[test]
fn cloth_behind_an_obstacle_still_shows() {
    let in_front = frame_pixels_with_sphere(1.5, "hidden");
    let behind = frame_pixels_with_sphere(-1.5, "visible");
    // Hidden behind the sphere, the sheet's outline is drawn dashed: at least a third of the
    // pixels it has in full view (the views' scales differ a little with the bounds).
    assert!(
        in_front * 3 >= behind,
        "{in_front} frame pixels behind the sphere, {behind} in full view"
    );
}

#[test]
fn top_view_ranges_have_equal_scale() {
    let (xr, yr) = equal_aspect([[-1.0, 1.0], [-1.5, 1.5]], (600, 500));
    let sx = 600.0 / (xr[1] - xr[0]);
    let sy = 500.0 / (yr[1] - yr[0]);
    assert!((sx - sy).abs() < 1e-9, "{sx} vs {sy}");
    assert!(xr[0] <= -1.0 && xr[1] >= 1.0 && yr[0] <= -1.5 && yr[1] >= 1.5);
    assert!(
        (yr[0] + 1.5).abs() < 1e-12,
        "y is the limiting axis and stays tight"
    );
}

#[test]
fn numbers_are_compact() {
    assert_eq!(fmt_num(0.0), "0");
    assert_eq!(fmt_num(0.5), "0.5");
    assert_eq!(fmt_num(0.123456), "0.123");
    assert_eq!(fmt_num(1234.0), "1234");
    assert_eq!(fmt_num(1e-5), "10⁻⁵");
    assert_eq!(fmt_num(2.5e-7), "2.5×10⁻⁷");
    assert_eq!(fmt_num(3e6), "3×10⁶");
    assert_eq!(fmt_tick(-1e-15), "0");
    assert_eq!(fmt_num(-0.25), "−0.25");
    assert_eq!(fmt_num(-1e-6), "−10⁻⁶");
}

/// A closed axis-aligned box `lo`–`hi` as 12 triangles.
fn cube(lo: [f64; 3], hi: [f64; 3], role: SolidRole) -> Solid {
    let vertices = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect();
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Solid {
        vertices,
        triangles,
        role,
        kind: "box".into(),
    }
}

/// Pixels of the plot area (left of the legend) that are shades of `base`: a channel ratio within
/// 3 % of the base colour's, the way [`crate::trajectory::prims`] shades triangles.
fn shade_pixels(path: &Path, base: RGBColor) -> usize {
    let (w, _, px) = decode(path);
    let ratio = |p: [u8; 3]| f64::from(p[0]) / f64::from(p[2].max(1));
    let target = f64::from(base.0) / f64::from(base.2);
    px.chunks(w as usize)
        .flat_map(|row| &row[..w as usize - 250])
        .filter(|p| p[0] < 250 && (ratio(**p) / target - 1.0).abs() < 0.03 && p[1] < p[0])
        .count()
}

#[test]
fn solids_are_drawn_depth_sorted_and_hide_the_cloth_behind_them() {
    let dir = scratch("solids");
    let sheet = sheet(1.0);
    let view = View3d::default();
    let eye = [
        view.yaw.sin() * view.pitch.cos(),
        -view.yaw.cos() * view.pitch.cos(),
        view.pitch.sin(),
    ];
    // A box on the line of sight through the sheet's centre, in front of it or behind it.
    let frame_pixels = |toward_camera: f64, name: &str| {
        let c: [f64; 3] = std::array::from_fn(|k| [0.0, 1.0, 1.5][k] + toward_camera * eye[k]);
        let solids = [cube(
            [c[0] - 0.7, c[1] - 0.7, c[2] - 0.7],
            [c[0] + 0.7, c[1] + 0.7, c[2] + 0.7],
            SolidRole::Collider,
        )];
        let fig = TrajectoryFigure {
            title: "box".into(),
            grid: (3, 3),
            frames: vec![(&sheet[..], "start".into())],
            solids: &solids,
            ..Default::default()
        };
        let path = dir.join(name);
        draw_trajectory_3d(&fig, &path).expect("3-D view");
        let (w, _, px) = decode(&path);
        let frame = px
            .chunks(w as usize)
            .flat_map(|row| &row[..w as usize - 250])
            .filter(|p| **p == [FRAME_COLORS[0].0, FRAME_COLORS[0].1, FRAME_COLORS[0].2])
            .count();
        (frame, shade_pixels(&path, SOLID_COLLIDER))
    };
    let (in_front, box_px) = frame_pixels(2.0, "front.png");
    let (behind, _) = frame_pixels(-2.0, "behind.png");
    assert!(box_px > 5000, "{box_px} pixels of the box's shades");
    // Behind the box only the dashed outline of the sheet shows (5 px of every 9), in front of it
    // the full lines too.
    assert!(
        (in_front as f64) < 0.85 * behind as f64,
        "{in_front} sheet pixels with the box in front, {behind} with it behind"
    );
    let bad = [Solid {
        vertices: vec![[0.0; 3]; 3],
        triangles: vec![[0, 1, 3]],
        role: SolidRole::Safety,
        kind: "mesh".into(),
    }];
    let fig = TrajectoryFigure {
        solids: &bad,
        ..Default::default()
    };
    let e = draw_trajectory_3d(&fig, &dir.join("bad.png")).unwrap_err();
    assert!(
        e.to_string()
            .contains("triangle 0 of solid 0 uses vertex 3"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_animation_has_one_frame_per_figure() {
    let dir = scratch("gif");
    let (a, b) = (sheet(-1.0), sheet(1.0));
    let figs: Vec<TrajectoryFigure> = [&a, &b]
        .iter()
        .map(|s| TrajectoryFigure {
            grid: (3, 3),
            frames: vec![(&s[..], "cloth".into())],
            ..Default::default()
        })
        .collect();
    let path = dir.join("a.gif");
    draw_trajectory_gif(&figs, 20, &path).expect("gif");
    let mut decoder = gif::DecodeOptions::new();
    decoder.set_color_output(gif::ColorOutput::RGBA);
    let mut d = decoder
        .read_info(std::fs::File::open(&path).expect("gif exists"))
        .expect("gif header");
    assert_eq!((d.width(), d.height()), (1000, 800));
    let mut frames = Vec::new();
    while let Some(f) = d.read_next_frame().expect("frame") {
        assert_eq!(f.delay, 20);
        frames.push(f.buffer.to_vec());
    }
    assert_eq!(frames.len(), 2);
    assert_ne!(frames[0], frames[1], "the cloth moved between the frames");
    assert!(matches!(
        draw_trajectory_gif(&figs, 20, &dir.join("a.png")),
        Err(PlotError::Write { .. })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_solid_triangle_nearer_the_viewer_is_painted_later() {
    let tri = |z: f64| Prim::Tri([[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]], BLACK);
    let quad = Prim::Quad([[0.0, 0.0, 1.0]; 4], BLACK.to_rgba());
    let order: Vec<f64> = paint_order(&Flat, vec![tri(2.0), quad, tri(0.0)])
        .iter()
        .map(|p| match p {
            Prim::Tri(t, _) => t[0][2],
            _ => 1.0,
        })
        .collect();
    // Flat's depth is −z: the lowest first.
    assert_eq!(order, [0.0, 1.0, 2.0]);
}

/// A legend whose labels are longer than the default column is widened to fit: its box
/// (grey border) ends inside the image in both views.
#[test]
fn a_long_legend_label_stays_inside_the_figure() {
    let dir = scratch("legend");
    let (a, b) = (sheet(-1.0), sheet(1.0));
    let long = "cloth: step 12 of a long plan, max strain 1234%".to_string();
    let fig = TrajectoryFigure {
        title: "long legend".into(),
        grid: (3, 3),
        frames: vec![(&a[..], "initial".into()), (&b[..], long)],
        ..Default::default()
    };
    let border = RGBColor(150, 150, 150);
    for name in ["3d.png", "top.png"] {
        let path = dir.join(name);
        draw_view(&fig, &path);
        let (w, h, px) = decode(&path);
        assert!(count(&px, border) > 100, "{name}: legend box");
        let last_columns = (0..h as usize)
            .flat_map(|y| (w as usize - 3..w as usize).map(move |x| y * w as usize + x));
        let clipped = last_columns
            .filter(|&i| px[i] == [border.0, border.1, border.2])
            .count();
        assert_eq!(
            clipped, 0,
            "{name}: the legend box reaches the image's right edge"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A box much longer in y than high (the `swing` scene's) puts the vertical axis's title beside
/// the box's left edge, where it ran off the image and showed as "[m]": the box now shrinks until
/// every axis title is inside, so the whole "z [m]", pixel for pixel as drawn alone, is found in
/// the image.
#[test]
fn axis_titles_stay_inside_a_wide_box() {
    let dir = scratch("titles");
    let (a, b) = (sheet(-1.5), sheet(1.0));
    let fig = TrajectoryFigure {
        title: "wide".into(),
        grid: (3, 3),
        frames: vec![(&a[..], "initial".into()), (&b[..], "final".into())],
        ..Default::default()
    };
    let path = dir.join("3d.png");
    draw_view(&fig, &path);
    let (w, _, px) = decode(&path);
    let label = draw_rgb((100, 40), |root| {
        let style = text(17.0).pos(Pos::new(HPos::Center, VPos::Center));
        root.draw(&Text::new("z [m]".to_string(), (50, 20), style))
            .map_err(de)
    })
    .expect("label");
    let at = |x: usize, y: usize| {
        [
            label[3 * (y * 100 + x)],
            label[3 * (y * 100 + x) + 1],
            label[3 * (y * 100 + x) + 2],
        ]
    };
    let inked: Vec<(usize, usize)> = (0..40)
        .flat_map(|y| (0..100).map(move |x| (x, y)))
        .filter(|&(x, y)| at(x, y) != [255, 255, 255])
        .collect();
    let (x0, y0) = (
        inked.iter().map(|p| p.0).min().expect("label drawn"),
        inked.iter().map(|p| p.1).min().expect("label drawn"),
    );
    let w = w as usize;
    let found = (0..px.len() / w - 40).any(|y| {
        (0..w - 100).any(|x| {
            inked
                .iter()
                .all(|&(lx, ly)| px[(y + ly - y0) * w + x + lx - x0] == at(lx, ly))
        })
    });
    assert!(found, "the vertical axis's title is not whole in the image");
    let _ = std::fs::remove_dir_all(&dir);
}

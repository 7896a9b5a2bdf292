//! `axisctl plot` through the real binary: a recording made by `record`
//! (JSON Lines and CSV) drawn to SVG, which the test opens and reads: one
//! line per recorded value, axis labels with units, the legend.

use crate::common;

use common::run;

/// The data lines of the SVG: polylines of the plot module's line width
/// (axes and ticks are drawn at width 1).
fn data_lines(svg: &str) -> usize {
    let width = format!("stroke-width=\"{}\"", axisctl::plot::LINE_WIDTH);
    svg.split("<polyline").skip(1).filter(|p| p.split('>').next().unwrap_or("").contains(&width)).count()
}

fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| Some(t[t.find('>')? + 1..t.find("</text>")?].trim().to_string()))
        .collect()
}

fn record_to(path: &std::path::Path, format: &str) {
    let r = run(&[
        "--link",
        "sim",
        "record",
        "--format",
        format,
        "-m",
        "17",
        "ActPos",
        "ActVel",
        "Cur",
        "--rate",
        "50",
        "--for",
        "0.4s",
        "--",
        "move-ramp",
        "-m",
        "17",
        "0.01",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::fs::write(path, r.stdout).unwrap();
}

#[test]
fn a_recording_becomes_an_svg_with_one_line_per_value_and_units_on_the_axes() {
    let dir = tempfile::tempdir().unwrap();
    for format in ["jsonl", "csv"] {
        let rec = dir.path().join(format!("step.{format}"));
        let svg_path = dir.path().join(format!("step-{format}.svg"));
        record_to(&rec, format);
        let r = run(&["--json", "plot", rec.to_str().unwrap(), "--svg", svg_path.to_str().unwrap()]);
        assert_eq!(r.code, 0, "{}", r.stderr);
        let doc = r.json();
        assert_eq!(doc["series"].as_array().unwrap().len(), 3, "{doc}");
        let svg = std::fs::read_to_string(&svg_path).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(data_lines(&svg), 3, "one line per recorded value ({format})");
        let texts = texts(&svg);
        for label in
            ["module 17 ActPos [m]", "module 17 ActVel [m/s]", "module 17 Cur [A]", "t (s)", &format!("step.{format}")]
        {
            assert!(texts.iter().any(|t| t == label), "{format}: no {label:?} in {texts:?}");
        }
    }
}

#[test]
fn every_device_and_value_is_its_own_series() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("two.jsonl");
    let r = run(&["--link", "sim", "--json", "record", "-m", "3,17", "ActPos", "--count", "4"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::fs::write(&rec, r.stdout).unwrap();
    let svg_path = dir.path().join("two.svg");
    let r = run(&["plot", rec.to_str().unwrap(), "--svg", svg_path.to_str().unwrap(), "--title", "two modules"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert_eq!(data_lines(&svg), 2);
    let texts = texts(&svg);
    // Module 3 is rotary, 17 linear: two units, two panels.
    assert!(texts.iter().any(|t| t == "module 3 ActPos [rad]") && texts.iter().any(|t| t == "module 17 ActPos [m]"));
    assert!(texts.iter().any(|t| t == "two modules"));
}

#[test]
fn a_file_that_is_no_recording_is_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.jsonl");
    std::fs::write(&bad, "{\"not\": \"a record line\"}\n").unwrap();
    let out = dir.path().join("out.svg");
    for rec in [bad.to_str().unwrap(), "/nonexistent/rec.csv"] {
        let r = run(&["plot", rec, "--svg", out.to_str().unwrap()]);
        assert_eq!(r.code, 2, "{}", r.stderr);
        assert!(!out.exists());
    }
}

/// A PNG's size and its RGB pixels (the plot module writes 8-bit RGB).
fn decode_png(path: &std::path::Path) -> ((u32, u32), Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.color_type, info.bit_depth), (png::ColorType::Rgb, png::BitDepth::Eight));
    let pixels = buf[..info.buffer_size()].chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    ((info.width, info.height), pixels)
}

#[test]
fn a_recording_becomes_a_png_of_the_size_asked_with_each_series_in_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("step.jsonl");
    record_to(&rec, "jsonl");
    let (png_path, svg_path) = (dir.path().join("step.png"), dir.path().join("step.svg"));
    let r = run(&[
        "--json",
        "plot",
        rec.to_str().unwrap(),
        "--png",
        png_path.to_str().unwrap(),
        "--svg",
        svg_path.to_str().unwrap(),
        "--width",
        "800",
        "--height",
        "900",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["png"], png_path.to_str().unwrap());
    assert_eq!(r.json()["svg"], svg_path.to_str().unwrap(), "both drawn in one run");
    let (size, pixels) = decode_png(&png_path);
    assert_eq!(size, (800, 900));
    assert_eq!(pixels.len(), 800 * 900);
    // Each series is a line of its own colour, far more pixels than its
    // legend mark (14x8) alone.
    for i in 0..3 {
        let (r, g, b) = axisctl::plot::colour(i);
        let n = pixels.iter().filter(|p| **p == [r, g, b]).count();
        assert!(n > 400, "series {i}: {n} pixels of its colour");
    }
    // Text is drawn with the embedded font: the title's row above the
    // panels holds nothing else, and has dark pixels.
    let white = pixels.iter().filter(|p| **p == [255, 255, 255]).count();
    let title_ink = pixels[..800 * 20].iter().filter(|p| p.iter().all(|c| *c < 100)).count();
    assert!(white > pixels.len() / 2 && title_ink > 40, "white {white}, title {title_ink}");
}

#[test]
fn a_png_too_large_to_hold_is_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("step.csv");
    record_to(&rec, "csv");
    let (png_path, svg_path) = (dir.path().join("big.png"), dir.path().join("big.svg"));
    let (p, s) = (png_path.to_str().unwrap(), svg_path.to_str().unwrap());
    let r = run(&["plot", rec.to_str().unwrap(), "--png", p, "--svg", s, "--width", "20000", "--height", "20000"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("too large"), "{}", r.stderr);
    assert!(!png_path.exists() && !svg_path.exists(), "no file of the run is written");
    let r = run(&["plot", rec.to_str().unwrap()]);
    assert_eq!(r.code, 2, "an output is required: {}", r.stderr);
}

//! A drawn screen (ratatui's buffer) as an SVG picture: monospace text in
//! the cells' colours, box-drawing lines as strokes so that they join.
//! docs/img/dashboard*.svg are made with it from the dashboard's own
//! drawing code (`scripts/screenshots.sh`), and a test keeps them current.

use std::fmt::Write;

use ratatui::buffer::Buffer;
use ratatui::style::{Color, Modifier};

/// A cell, in pixels.
const CELL_W: f64 = 8.4;
const CELL_H: f64 = 17.0;
const FONT_SIZE: f64 = 14.0;
const FG: &str = "#d4d4d4";
const BG: &str = "#1e1e1e";

/// A terminal palette (VS Code's dark one) for the named colours.
fn hex(c: Color, default: &str) -> String {
    let named = match c {
        Color::Reset => default,
        Color::Black => "#000000",
        Color::Red => "#cd3131",
        Color::Green => "#0dbc79",
        Color::Yellow => "#e5e510",
        Color::Blue => "#2472c8",
        Color::Magenta => "#bc3fbc",
        Color::Cyan => "#11a8cd",
        Color::Gray => "#e5e5e5",
        Color::DarkGray => "#767676",
        Color::LightRed => "#f14c4c",
        Color::LightGreen => "#23d18b",
        Color::LightYellow => "#f5f543",
        Color::LightBlue => "#3b8eea",
        Color::LightMagenta => "#d670d6",
        Color::LightCyan => "#29b8db",
        Color::White => "#ffffff",
        Color::Rgb(r, g, b) => return format!("#{r:02x}{g:02x}{b:02x}"),
        Color::Indexed(i) => return format!("#{i:02x}{i:02x}{i:02x}"),
    };
    named.to_string()
}

/// Which sides of its cell a box-drawing character reaches: left, right,
/// up, down.
fn box_sides(symbol: &str) -> Option<[bool; 4]> {
    Some(match symbol {
        "─" => [true, true, false, false],
        "│" => [false, false, true, true],
        "┌" => [false, true, false, true],
        "┐" => [true, false, false, true],
        "└" => [false, true, true, false],
        "┘" => [true, false, true, false],
        "├" => [false, true, true, true],
        "┤" => [true, false, true, true],
        "┬" => [true, true, false, true],
        "┴" => [true, true, true, false],
        "┼" => [true, true, true, true],
        _ => return None,
    })
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The colours and weight a cell is drawn with.
#[derive(Clone, PartialEq)]
struct Look {
    fg: String,
    bg: String,
    bold: bool,
    dim: bool,
}

fn look(cell: &ratatui::buffer::Cell) -> Look {
    let (mut fg, mut bg) = (hex(cell.fg, FG), hex(cell.bg, BG));
    if cell.modifier.contains(Modifier::REVERSED) {
        std::mem::swap(&mut fg, &mut bg);
    }
    Look { fg, bg, bold: cell.modifier.contains(Modifier::BOLD), dim: cell.modifier.contains(Modifier::DIM) }
}

/// The buffer as an SVG document.
pub fn svg(buf: &Buffer) -> String {
    let area = buf.area;
    let (w, h) = (f64::from(area.width) * CELL_W, f64::from(area.height) * CELL_H);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.1} {h:.1}\" \
         font-family=\"'DejaVu Sans Mono', Menlo, Consolas, monospace\" font-size=\"{FONT_SIZE}\" xml:space=\"preserve\">"
    );
    let _ = writeln!(out, "<rect width=\"100%\" height=\"100%\" fill=\"{BG}\"/>");
    // Box lines in half cells: (colour, vertical, at, from, to).
    let mut lines: Vec<(String, bool, f64, f64, f64)> = Vec::new();
    for y in 0..area.height {
        let top = f64::from(y) * CELL_H;
        // Runs of one look: a background rectangle where it is not the
        // screen's, one text element for the characters.
        let mut x = 0;
        while x < area.width {
            let first = look(&buf[(area.x + x, area.y + y)]);
            let mut end = x;
            let mut text = String::new();
            while end < area.width && look(&buf[(area.x + end, area.y + y)]) == first {
                let cell = &buf[(area.x + end, area.y + y)];
                let s = cell.symbol();
                if let Some([l, r, u, d]) = box_sides(s) {
                    // Strokes from the middle of the cell to the sides it reaches.
                    let (cx, cy) = (f64::from(end) * 2.0 + 1.0, f64::from(y) * 2.0 + 1.0);
                    if l || r {
                        let (a, b) = (if l { cx - 1.0 } else { cx }, if r { cx + 1.0 } else { cx });
                        lines.push((first.fg.clone(), false, cy, a, b));
                    }
                    if u || d {
                        let (a, b) = (if u { cy - 1.0 } else { cy }, if d { cy + 1.0 } else { cy });
                        lines.push((first.fg.clone(), true, cx, a, b));
                    }
                    text.push(' ');
                } else {
                    text.push_str(if s.is_empty() { " " } else { s });
                }
                end += 1;
            }
            let left = f64::from(x) * CELL_W;
            let width = f64::from(end - x) * CELL_W;
            if first.bg != BG {
                let _ = writeln!(
                    out,
                    "<rect x=\"{left:.1}\" y=\"{top:.1}\" width=\"{width:.1}\" height=\"{CELL_H}\" fill=\"{}\"/>",
                    first.bg
                );
            }
            let trimmed = text.trim_end();
            if !trimmed.trim_start().is_empty() {
                let cells = trimmed.chars().count();
                let mut attrs = format!("fill=\"{}\"", first.fg);
                if first.bold {
                    attrs.push_str(" font-weight=\"bold\"");
                }
                if first.dim {
                    attrs.push_str(" opacity=\"0.6\"");
                }
                // textLength pins the text to its cells whatever the font's advance.
                let _ = writeln!(
                    out,
                    "<text x=\"{left:.1}\" y=\"{:.1}\" textLength=\"{:.1}\" lengthAdjust=\"spacingAndGlyphs\" {attrs}>{}</text>",
                    top + CELL_H * 0.78,
                    cells as f64 * CELL_W,
                    escape(trimmed)
                );
            }
            x = end;
        }
    }
    strokes(&mut out, lines);
    out.push_str("</svg>\n");
    out
}

/// The box lines, joined where they meet end to end: one path per colour.
fn strokes(out: &mut String, mut lines: Vec<(String, bool, f64, f64, f64)>) {
    lines.sort_by(|a, b| (&a.0, a.1, a.2, a.3).partial_cmp(&(&b.0, b.1, b.2, b.3)).expect("finite"));
    let mut joined: Vec<(String, bool, f64, f64, f64)> = Vec::new();
    for l in lines {
        match joined.last_mut() {
            Some(j) if j.0 == l.0 && j.1 == l.1 && j.2 == l.2 && l.3 <= j.4 => j.4 = j.4.max(l.4),
            _ => joined.push(l),
        }
    }
    let (hw, hh) = (CELL_W / 2.0, CELL_H / 2.0);
    let mut i = 0;
    while i < joined.len() {
        let colour = joined[i].0.clone();
        let mut d = String::new();
        while i < joined.len() && joined[i].0 == colour {
            let (_, vertical, at, a, b) = &joined[i];
            if *vertical {
                let _ = write!(d, "M{:.1} {:.1}V{:.1}", at * hw, a * hh, b * hh);
            } else {
                let _ = write!(d, "M{:.1} {:.1}H{:.1}", a * hw, at * hh, b * hw);
            }
            i += 1;
        }
        let _ = writeln!(out, "<path d=\"{d}\" stroke=\"{colour}\" stroke-width=\"1\" fill=\"none\"/>");
    }
}

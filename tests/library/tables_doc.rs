//! docs/powercube.md's tables are generated from the protocol tables, so
//! they cannot drift. Regenerate with `UPDATE_DOCS=1 cargo test --test library tables_doc`.

use std::fmt::Write;

use axisctl::proto::powercube::{flags, table};

const START: &str = "<!-- generated from src/proto/powercube: start -->";
const END: &str = "<!-- generated from src/proto/powercube: end -->";

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

fn generate() -> String {
    let mut s = String::new();
    s.push_str("### Commands (manual 4.4)\n\n| id | name | description |\n|---|---|---|\n");
    for c in table::COMMANDS {
        writeln!(s, "| `{:#04x}` | {} | {} |", c.id as u8, c.name, cell(c.description)).unwrap();
    }
    s.push_str("\n### Motion ids (manual 4.5)\n\n| id | name | argument | time | acknowledge | unit |\n|---|---|---|---|---|---|\n");
    for m in table::MOTIONS {
        writeln!(
            s,
            "| {} | {} | {:?} | {} | {} | {} |",
            m.id,
            m.name,
            m.arg,
            if m.timed { "UInt16 ms" } else { "" },
            if m.extended_ack { "extended" } else { "simple" },
            cell(m.unit)
        )
        .unwrap();
    }
    s.push_str("\n### Parameters (manual 4.6)\n\n| id | name | type | unit | access | class | description |\n|---|---|---|---|---|---|---|\n");
    for p in table::PARAMS {
        writeln!(
            s,
            "| `{:#04x}` ({}) | {} | {} | {} | {:?} | {:?} | {} |",
            p.id,
            p.id,
            p.name,
            p.ty.name(),
            cell(p.unit),
            p.access,
            p.class,
            cell(p.description)
        )
        .unwrap();
    }
    for w in flags::WORDS {
        writeln!(
            s,
            "\n### {} (`decode {}`)\n\n| mask | flag | short | class | meaning |\n|---|---|---|---|---|",
            w.name, w.kind
        )
        .unwrap();
        for f in w.flags {
            writeln!(
                s,
                "| `{:#0width$x}` | {} | {} | {:?} | {} |",
                f.mask,
                f.name,
                f.short.unwrap_or(""),
                f.class,
                cell(f.description),
                width = (w.bits / 4) as usize + 2
            )
            .unwrap();
        }
    }
    s
}

#[test]
fn powercube_tables_in_docs_are_generated_from_the_code() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/powercube.md");
    let doc = std::fs::read_to_string(path).unwrap();
    let (head, rest) = doc.split_once(START).expect("start marker");
    let (_, tail) = rest.split_once(END).expect("end marker");
    let fresh = format!("{head}{START}\n{}{END}{tail}", generate());
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(path, &fresh).unwrap();
    } else {
        assert!(fresh == doc, "docs/powercube.md is stale: run UPDATE_DOCS=1 cargo test --test library tables_doc");
    }
}

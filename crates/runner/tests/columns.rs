//! The one table of stored columns is what the documentation shows, what the writer writes and
//! what axes may not be named.

use chainsweep::record::columns::{
    markdown_table, reserved_names, ARRAY_NAMES, COLUMNS, LAYOUT_NAMES, SEARCH_LAYOUT_NAMES,
    SPLIT_NAMES,
};
use chainsweep::sweep::Sweep;

const BEGIN: &str =
    "<!-- columns: generated from crates/sweep/src/record/columns/; checked by crates/runner/tests/columns.rs -->\n";
const END: &str = "<!-- /columns -->";

#[test]
fn the_docs_table_is_the_column_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/REFERENCE.md");
    let doc = std::fs::read_to_string(path).unwrap();
    let start = doc
        .find(BEGIN)
        .expect("docs/REFERENCE.md has the columns marker")
        + BEGIN.len();
    let end = doc[start..].find(END).expect("and its end marker") + start;
    let want = markdown_table();
    assert!(
        doc[start..end] == want,
        "docs/REFERENCE.md's column table differs from record::columns::COLUMNS; put this between the markers:\n{want}"
    );
}

#[test]
fn an_axis_may_take_no_stored_name() {
    let names = reserved_names();
    assert_eq!(
        names.len(),
        COLUMNS.len()
            + LAYOUT_NAMES.len()
            + ARRAY_NAMES.len()
            + SEARCH_LAYOUT_NAMES.len()
            + SPLIT_NAMES.len()
    );
    for name in names {
        let text = format!(
            r#"{{"base": {{"chain": {{"preset": "chain_055", "cylinders": 4}}, "physics": {{"gravity": true, "damping_kg_s": 0.0, "wall": true}}, "striker_velocity_m_s": 1.3, "duration_s": 1e-5}},
               "axes": [{{"field": "physics.damping_kg_s", "name": "{name}", "values": [0, 1]}}]}}"#
        );
        let err = Sweep::parse(&text).unwrap_err().to_string();
        assert!(
            err.contains("axes[0].name") && err.contains("reserved"),
            "{name}: {err}"
        );
    }
}

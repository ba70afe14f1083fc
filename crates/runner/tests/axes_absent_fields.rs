//! An axis may set a field the normalised base leaves out because it holds its default (the
//! solver skips such fields when it serialises a scene, so that existing scenes keep their run
//! hashes): the missing objects are created when values are applied, and every grid point is then
//! deserialised and validated, naming the axis when a value or the field itself is not allowed.

use chainsweep::error::Error;
use chainsweep::grid::Grid;
use chainsweep::sweep::Sweep;

fn sweep(axes: &str) -> String {
    format!(
        r#"{{
  "base": {{
    "chain": {{"preset": "chain_098", "cylinders": 5}},
    "physics": {{"gravity": false, "damping_kg_s": 0.0, "wall": true}},
    "striker_velocity_m_s": 1.0,
    "duration_s": 1e-4
  }},
  "axes": [{axes}]
}}"#
    )
}

fn input_error(text: &str) -> (String, String) {
    let err = Sweep::parse(text)
        .and_then(|s| Grid::new(&s).map(|_| ()))
        .unwrap_err();
    match err {
        Error::Input { field, message, .. } => (field, message),
        other => panic!("expected an input error, got {other}"),
    }
}

#[test]
fn absent_fields_are_created_along_the_path() {
    let s = Sweep::parse(&sweep(
        r#"{"field": "physics.precompression_force_n", "values": [0, 2.5]},
           {"field": "physics.dissipation.kuwabara_kono.relaxation_time_s", "values": [1e-7]}"#,
    ))
    .unwrap();
    assert!(s.base["physics"].get("precompression_force_n").is_none());
    let grid = Grid::new(&s).unwrap();
    let scene = grid.build(&s, 1).unwrap();
    assert_eq!(scene.physics.precompression_force_n, 2.5);
    assert_eq!(
        scene.physics.dissipation,
        Some(chainsweep_solver::contact::DissipationSpec::KuwabaraKono {
            relaxation_time_s: 1e-7
        })
    );
    // A value equal to the default serialises as the default, so the point keeps the run hash
    // of the same scene without the axis.
    let zero = Sweep::parse(&sweep(
        r#"{"field": "physics.precompression_force_n", "values": [0, 1]}"#,
    ))
    .unwrap();
    let plain = Sweep::parse(&sweep(r#"{"field": "duration_s", "values": [1e-4]}"#)).unwrap();
    assert_eq!(
        Grid::new(&zero).unwrap().hashes[0],
        Grid::new(&plain).unwrap().hashes[0]
    );
}

#[test]
fn unknown_fields_name_the_axis_and_the_allowed_fields() {
    let (field, message) = input_error(&sweep(r#"{"field": "physics.dampingg", "values": [1]}"#));
    // The field is at fault, whatever its values.
    assert_eq!(field, "axes[0].field");
    assert!(message.contains("physics.dampingg"), "{message}");
    assert!(message.contains("damping_kg_s"), "{message}");
}

#[test]
fn bad_values_of_absent_fields_name_the_axis() {
    let (field, message) = input_error(&sweep(
        r#"{"field": "physics.precompression_force_n", "values": [1, -3]}"#,
    ));
    assert_eq!(field, "axes[0].values[1]");
    assert!(message.contains("precompression_force_n"), "{message}");
}

#[test]
fn paths_through_plain_values_or_past_lists_are_refused_at_parse_time() {
    let (field, _) = input_error(&sweep(r#"{"field": "duration_s.x", "values": [1]}"#));
    assert_eq!(field, "axes[0].field");
    let (field, _) = input_error(&sweep(
        r#"{"field": "record.probes[3].cylinder", "values": [1]}"#,
    ));
    assert_eq!(field, "axes[0].field");
}

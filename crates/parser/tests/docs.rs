//! docs/scene-format.md documents every plugin the parser accepts: its status table has a row
//! "| kind | `name` ... |" for each (kind, name) of `torrey_parser::accepted_plugins()`.

#[test]
fn every_accepted_plugin_is_in_the_status_table() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    let doc = std::fs::read_to_string(&path).expect("docs/scene-format.md");
    let table = doc
        .split("## Mitsuba 3 plugins and features: status")
        .nth(1)
        .expect("the status table section");
    let mut missing = Vec::new();
    let mut count = 0;
    for (kind, names) in torrey_parser::accepted_plugins() {
        for name in names {
            count += 1;
            let documented = table.lines().any(|l| {
                let cells: Vec<&str> = l.split('|').map(str::trim).collect();
                cells.len() > 3
                    && cells[1] == kind
                    && cells[2].split(", ").any(|c| c == format!("`{name}`"))
            });
            if !documented {
                missing.push(format!("{kind} `{name}`"));
            }
        }
    }
    assert!(count > 30, "only {count} plugin names");
    assert!(missing.is_empty(), "not in the status table: {missing:?}");
}

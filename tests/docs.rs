//! The documentation's lists of what the code defines stay complete: the `[render] integrator`
//! values of `scenes/README.md` are the registered integrators, and the effects table there has
//! one row per effect, in order, whose cells say for every method what its `support` says
//! (simulates, approximates, ignores); the README names every effect too.

use vitrum::integrators;
use vitrum::scene::effects::{Effect, Support};

const SCENES_README: &str = include_str!("../scenes/README.md");
const README: &str = include_str!("../README.md");

/// The names in backticks in `text`, in order.
fn quoted(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

/// The cells of a Markdown table row, trimmed.
fn cells(row: &str) -> Vec<&str> {
    row.trim().trim_matches('|').split('|').map(str::trim).collect()
}

#[test]
fn the_render_integrator_values_are_every_registered_integrator() {
    let row = SCENES_README
        .lines()
        .find(|l| l.starts_with("| `integrator` |"))
        .expect("scenes/README.md documents `[render] integrator`");
    let meaning = cells(row)[1];
    // "method: `raycast`, …, `vcm` (`vitrum integrators`)": the names before the command.
    let listed = meaning.split("(`vitrum integrators`)").next().unwrap();
    assert_eq!(quoted(listed), integrators::names(), "{row}");
}

#[test]
fn the_effects_table_says_what_every_method_does_with_every_effect() {
    let mut rows = SCENES_README.lines().skip_while(|l| !l.starts_with("| effect | called for by |"));
    let header = cells(rows.next().expect("scenes/README.md has the effects table"));
    // Each method column names its methods; together they are every integrator, once each.
    let columns: Vec<(usize, Vec<&str>)> =
        header.iter().enumerate().skip(2).map(|(i, h)| (i, quoted(h))).collect();
    let mut methods: Vec<&str> = columns.iter().flat_map(|(_, m)| m.iter().copied()).collect();
    let mut names = integrators::names();
    methods.sort_unstable();
    names.sort_unstable();
    assert_eq!(methods, names, "the effects table's columns: {header:?}");

    let body: Vec<Vec<&str>> = rows.skip(1).take_while(|l| l.starts_with('|')).map(cells).collect();
    let effects: Vec<&str> = body.iter().map(|r| r[0].trim_matches('`')).collect();
    let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
    assert_eq!(effects, all, "one row per effect, in the order of `vitrum info`");
    for (row, effect) in body.iter().zip(Effect::ALL) {
        assert_eq!(row.len(), header.len(), "{effect}: {row:?}");
        for (column, names) in &columns {
            let cell = row[*column];
            for name in names {
                let support = integrators::create(name).unwrap().support(effect);
                let word = match support {
                    Support::Simulates => "simulates",
                    Support::Approximates(_) => "approximates",
                    Support::Ignores(_) => "ignores",
                };
                assert!(
                    cell.starts_with(word),
                    "{effect}, `{name}`: the table says {cell:?}, the code {support:?}"
                );
            }
        }
    }
}

#[test]
fn the_readme_names_every_effect() {
    let start =
        README.find("### Effects: simulate only what the scene calls for").expect("the Effects section");
    let section = &README[start..];
    let paragraph = &section[..section.find("`vitrum info` lists them").expect("the list of effects")];
    let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
    let named: Vec<&str> = quoted(paragraph).into_iter().filter(|q| all.contains(q)).collect();
    assert_eq!(named, all, "the README's effects, in the order of `vitrum info`");
}

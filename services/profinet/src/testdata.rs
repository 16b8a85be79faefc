//! Golden frames of the `pnio` crate (see `testdata/pnio/README.md`), for the unit tests.

use std::path::Path;

/// The bytes of `testdata/pnio/<name>.hex`: one frame as hex pairs, `#` lines are comments.
pub fn frame(name: &str) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata/pnio")
        .join(format!("{name}.hex"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    text.lines()
        .filter(|line| !line.trim_start().starts_with('#'))
        .flat_map(str::split_whitespace)
        .map(|pair| {
            u8::from_str_radix(pair, 16).unwrap_or_else(|e| panic!("{path:?}: {pair}: {e}"))
        })
        .collect()
}

//! Text clouds (.xyz, .xyzn, .txt, .pts, .csv). The first byte chooses the
//! columns: even, from the file (its header or column count); odd, the first
//! line after it is a `--columns` value and the rest the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::xyz::{self, Columns};
use vsaqem_fuzz::check_cloud;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode % 2 == 0 {
        check_cloud(xyz::parse_cloud(rest, None));
        return;
    }
    let (spec, file) = match rest.iter().position(|&b| b == b'\n') {
        Some(i) => (&rest[..i], &rest[i + 1..]),
        None => (rest, &[][..]),
    };
    let Ok(spec) = std::str::from_utf8(spec) else {
        return;
    };
    if let Ok(columns) = spec.parse::<Columns>() {
        check_cloud(xyz::parse_cloud(file, Some(&columns)));
    }
});

//! The mesh readers OBJ, OFF and STL (ASCII and binary); the first byte
//! chooses the reader, the rest is the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::{obj, off, stl};
use vsaqem_fuzz::check_mesh;

fuzz_target!(|data: &[u8]| {
    let Some((&which, file)) = data.split_first() else {
        return;
    };
    check_mesh(match which % 3 {
        0 => obj::parse_mesh(file),
        1 => off::parse_mesh(file),
        _ => stl::parse_mesh(file),
    });
});

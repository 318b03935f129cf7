//! PLY (ASCII and binary, either endianness): as a cloud and as a mesh.
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::ply;
use vsaqem_fuzz::{check_cloud, check_mesh};

fuzz_target!(|data: &[u8]| {
    check_cloud(ply::parse_cloud(data));
    check_mesh(ply::parse_mesh(data));
});

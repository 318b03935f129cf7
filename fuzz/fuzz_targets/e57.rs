//! E57 (the `e57` crate: XML section, binary sections, CRC pages).
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::e57;
use vsaqem_fuzz::check_cloud;

fuzz_target!(|data: &[u8]| check_cloud(e57::parse_cloud(data.to_vec())));

//! LAS and LAZ (the `las` crate and its `laz` decoder, whose panics the reader
//! turns into errors).
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::las;
use vsaqem_fuzz::check_cloud;

fuzz_target!(|data: &[u8]| check_cloud(las::parse_cloud(data.to_vec())));

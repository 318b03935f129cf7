//! PCD (ascii, binary, binary_compressed with its LZF decoder).
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::io::pcd;
use vsaqem_fuzz::check_cloud;

fuzz_target!(|data: &[u8]| check_cloud(pcd::parse_cloud(data)));

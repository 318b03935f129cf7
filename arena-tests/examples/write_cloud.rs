//! Write a generated cloud as a binary PLY (float x y z), e.g. to measure the
//! whole CLI on a million points:
//! `cargo run --release -p arena-tests --example write_cloud -- demo 1000000 /tmp/demo_1m.ply`

use arena_tests::cloud;
use std::io::Write;
use vsaqem_core::sample::Shape;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [shape, n, path] = args.as_slice() else {
        eprintln!("usage: write_cloud SHAPE POINTS OUT.ply");
        std::process::exit(2);
    };
    let shape = Shape::from_name(shape).expect("shape: demo, sphere, torus, box or cylinder");
    let n: usize = n.parse().expect("points");
    let points = cloud(shape, n, 1);
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).expect("create"));
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\n\
         property float x\nproperty float y\nproperty float z\nend_header\n"
    )
    .unwrap();
    for p in &points {
        for c in p {
            out.write_all(&c.to_le_bytes()).unwrap();
        }
    }
    out.flush().unwrap();
}

//! How far the B&B's gap on a real problem is from the LP relaxation: builds the
//! selection problem of a cloud at N clusters, runs the B&B, and solves the LP
//! relaxation (the MIP model of `tests/select_oracle.rs` with continuous variables)
//! with microlp. `cargo run --release -p arena-tests --example lp_gap -- CLOUD.ply [CLUSTERS]`
use std::mem::MaybeUninit;
use std::time::Instant;

use arena_tests::load_shared_cloud;
use good_lp::{microlp, variable, Expression, ProblemVariables, SolverModel};
use vsaqem_core::meshing::select::{try_select_in, MASK_AT_MOST_ONE, UNUSED};
use vsaqem_core::{arena_bytes, cluster, selection_problem, Arena, Params, Silent};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::PathBuf::from(args.get(1).expect("usage: lp_gap CLOUD.ply [CLUSTERS]"));
    let clusters = args.get(2).map_or(1000, |s| s.parse().unwrap());
    let params = Params {
        clusters,
        ..Params::default()
    };
    let pts = load_shared_cloud(&path);
    let mut buf = vec![MaybeUninit::<u8>::uninit(); 4 * arena_bytes(pts.len(), &params)];
    let arena = Arena::new(&mut buf);
    let clustered = cluster(&arena, &pts, None, &params, &mut Silent).unwrap();
    let p = selection_problem(&arena, &pts, &clustered, &params).unwrap();
    let t = Instant::now();
    let (_, st) = try_select_in(&arena, &p.input(params.node_limit), &mut |_, _| true).unwrap();
    println!(
        "{} facets, {} constraints; B&B objective {:.4}, bound {:.4}, gap {:.3}%, optimal {} ({} nodes, {:.0} ms)",
        p.rows.len(),
        p.masks.len(),
        st.objective,
        st.upper_bound,
        100.0 * st.gap,
        st.optimal,
        st.nodes,
        t.elapsed().as_secs_f64() * 1e3
    );
    // The LP relaxation of the oracle's model.
    let mut vars = ProblemVariables::new();
    let b: Vec<_> = (0..p.rows.len())
        .map(|_| vars.add(variable().min(0.0).max(1.0)))
        .collect();
    let mut incident = vec![Vec::new(); p.masks.len()];
    for (f, row) in p.rows.iter().enumerate() {
        for &e in row.iter().filter(|&&e| e != UNUSED) {
            incident[e as usize].push(f);
        }
    }
    let amo = |f: usize| {
        p.rows[f]
            .iter()
            .filter(move |&&e| e != UNUSED && p.masks[e as usize] == MASK_AT_MOST_ONE)
    };
    let exclusive = |f: usize, g: usize| amo(f).any(|e| amo(g).any(|h| h == e));
    let mut objective = Expression::default();
    for (f, &w) in p.scores.iter().enumerate() {
        objective.add_mul(w as f64, b[f]);
    }
    let mut cons = Vec::new();
    for (e, fs) in incident.iter().enumerate() {
        if fs.is_empty() {
            continue;
        }
        let m = p.masks[e];
        let mut degree = Expression::default();
        for &f in fs {
            degree += b[f];
        }
        if m == MASK_AT_MOST_ONE && p.penalties[e] == 0.0 {
            cons.push(degree.leq(1.0));
            continue;
        }
        let (mut chosen, mut levels, mut single) = (
            Expression::default(),
            Expression::default(),
            Expression::default(),
        );
        for d in 1..=2u8 {
            if (m >> d) & 1 == 1 {
                let z = vars.add(variable().min(0.0).max(1.0));
                chosen.add_mul(d as f64, z);
                levels += z;
                if d == 1 {
                    objective.add_mul(-(p.penalties[e] as f64), z);
                    single += z;
                }
            }
        }
        cons.push(degree.eq(chosen));
        cons.push(levels.leq(1.0));
        for &f in fs {
            let mut others = single.clone();
            for &g in fs {
                if g != f && !exclusive(f, g) {
                    others += b[g];
                }
            }
            cons.push(Expression::from(b[f]).leq(others));
        }
    }
    let t = Instant::now();
    let mut model = vars.maximise(objective.clone()).using(microlp);
    for c in cons {
        model = model.with(c);
    }
    let sol = model.solve().expect("LP solved");
    let lp = objective.eval_with(&sol);
    println!(
        "LP relaxation {:.4} ({:.0} ms): B&B incumbent is {:.3}% below it, B&B bound {:.3}% above it",
        lp,
        t.elapsed().as_secs_f64() * 1e3,
        100.0 * (lp - st.objective) / lp,
        100.0 * (st.upper_bound - lp) / lp
    );
}

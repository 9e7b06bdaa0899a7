//! Engine benchmarks (not tests): `cargo bench --bench engine`.
//!
//! 1. No-op rerun: a 10-node graph whose first node reads a 10 MB file, everything cached; wall
//!    time of load + plan + run (goal: at most 100 ms).
//! 2. Per-node engine overhead on a 1000-node chain of trivial nodes (goal: at most 50 µs per
//!    node), without a cache, with a cold cache (every value written), and fully cached.
//!
//! Prints the median of several repetitions.

#[path = "../tests/common/mod.rs"]
mod common;

use std::fmt::Write as _;
use std::time::Instant;

use crestflow_flow::{load_file, run, RunOptions, Status};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let reg = common::toy_registry();
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    println!("crestflow engine benchmarks ({threads} threads)");

    // 1. No-op rerun of a 10-node graph reading a 10 MB file.
    let dir = common::tempdir();
    let big: Vec<u8> = (0..10_000_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect();
    std::fs::write(dir.path().join("big.bin"), &big).expect("write input");
    let mut g = String::from(
        "Graph(nodes: {\n  \"n0\": (kind: \"toy.read_file\", params: (path: \"big.bin\")),\n",
    );
    let _ = writeln!(
        g,
        "  \"n1\": (kind: \"toy.add\", inputs: {{ \"a\": \"n0.len\" }}),"
    );
    for i in 2..10 {
        let _ = writeln!(g, "  \"n{i}\": (kind: \"toy.add\", params: (offset: 1.0), inputs: {{ \"a\": \"n{}.sum\" }}),", i - 1);
    }
    g.push_str("})\n");
    let path = common::write(dir.path(), "ten.ron", &g);
    let first = Instant::now();
    let plan = load_file(&path, &reg, &[]).expect("graph loads");
    let s = run(&plan, &RunOptions::default()).expect("run");
    assert_eq!(s.count(Status::Ran), 10);
    println!(
        "10-node graph, first run (reads and caches 10 MB): {:.1} ms",
        first.elapsed().as_secs_f64() * 1e3
    );
    let mut times = Vec::new();
    for _ in 0..21 {
        let t = Instant::now();
        let plan = load_file(&path, &reg, &[]).expect("graph loads");
        let s = run(&plan, &RunOptions::default()).expect("run");
        times.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(s.count(Status::Cached), 10);
    }
    println!(
        "10-node graph, no-op rerun (all cached): median {:.2} ms over 21 runs (goal <= 100 ms)",
        median(times)
    );

    // 2. A 1000-node chain of trivial nodes.
    let n = 1000;
    let mut g = String::from("Graph(nodes: {\n  \"c\": (kind: \"toy.const\", params: (value: 0.5)),\n  \"a0\": (kind: \"toy.add\", inputs: { \"a\": \"c.value\" }),\n");
    for i in 1..n - 1 {
        let _ = writeln!(g, "  \"a{i}\": (kind: \"toy.add\", params: (offset: 1.0), inputs: {{ \"a\": \"a{}.sum\" }}),", i - 1);
    }
    g.push_str("})\n");
    let chain = common::write(dir.path(), "chain.ron", &g);
    let plan = load_file(&chain, &reg, &[]).expect("chain loads");
    assert_eq!(plan.nodes.len(), n);
    let per_node = |opts: &dyn Fn(usize) -> RunOptions, expect: Status| {
        let mut v = Vec::new();
        for rep in 0..7 {
            let t = Instant::now();
            let s = run(&plan, &opts(rep)).expect("run");
            v.push(t.elapsed().as_secs_f64() * 1e6 / n as f64);
            assert_eq!(s.count(expect), n);
        }
        median(v)
    };
    let no_cache = per_node(
        &|_| RunOptions {
            use_cache: false,
            ..Default::default()
        },
        Status::Ran,
    );
    let cold = per_node(
        &|rep| RunOptions {
            cache_dir: Some(dir.path().join(format!("cold{rep}"))),
            ..Default::default()
        },
        Status::Ran,
    );
    let warm = per_node(
        &|_| RunOptions {
            cache_dir: Some(dir.path().join("cold0")),
            ..Default::default()
        },
        Status::Cached,
    );
    println!("1000-node chain, per-node overhead (goal <= 50 us/node):");
    println!("  no cache:    {no_cache:.1} us/node");
    println!("  cold cache:  {cold:.1} us/node (every output encoded, hashed and written)");
    println!("  all cached:  {warm:.1} us/node");
    let t = Instant::now();
    for _ in 0..5 {
        let _ = load_file(&chain, &reg, &[]).expect("chain loads");
    }
    println!(
        "  loading the 1000-node file: {:.1} us/node",
        t.elapsed().as_secs_f64() * 1e6 / 5.0 / n as f64
    );
}

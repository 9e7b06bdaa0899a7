use super::Par;

#[test]
fn install_moves_a_rayon_run_onto_a_pool_thread_and_keeps_a_sequential_one_here() {
    assert_eq!(rayon::current_thread_index(), None);
    assert!(Par::Rayon.install(|| rayon::current_thread_index().is_some()));
    assert_eq!(Par::Seq.install(rayon::current_thread_index), None);
    // Already on a pool thread: stays on that very thread.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (outer, inner) = pool.install(|| {
        let outer = std::thread::current().id();
        (outer, Par::Rayon.install(|| std::thread::current().id()))
    });
    assert_eq!(outer, inner);
}

#[test]
fn join_returns_both_results_in_order() {
    for par in [Par::Seq, Par::Rayon] {
        let data: Vec<u64> = (1..=1000).collect();
        let (a, b) = par.join(
            || data.iter().sum::<u64>(),
            || data.iter().map(|x| x * x).sum::<u64>(),
        );
        assert_eq!((a, b), (500_500, 333_833_500));
    }
}

#[test]
fn for_each_chunk_mut_hands_out_every_part_once_with_its_start() {
    for par in [Par::Seq, Par::Rayon] {
        for chunk in [0, 1, 7, 1000, 5000] {
            let mut data = vec![0usize; 1000];
            // Each element gets its own index plus one, written through its part.
            par.for_each_chunk_mut(&mut data, chunk, |start, part| {
                assert!(part.len() <= chunk.max(1));
                for (i, x) in part.iter_mut().enumerate() {
                    *x += start + i + 1;
                }
            });
            assert_eq!(
                data,
                (1..=1000).collect::<Vec<_>>(),
                "{par:?}, chunk {chunk}"
            );
        }
    }
    let mut empty: Vec<u8> = Vec::new();
    Par::Rayon.for_each_chunk_mut(&mut empty, 4, |_, _| panic!("no part of an empty slice"));
}

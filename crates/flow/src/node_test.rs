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
fn map_init_collect_keeps_index_order_and_reuses_scratch() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    for par in [Par::Seq, Par::Rayon] {
        let inits = AtomicUsize::new(0);
        // The scratch counts the indices its holder mapped; the result is the index squared.
        let out = par.map_init_collect(
            10_000,
            || {
                inits.fetch_add(1, Ordering::Relaxed);
                0usize
            },
            |seen, i| {
                *seen += 1;
                i * i
            },
        );
        assert_eq!(
            out,
            (0..10_000).map(|i| i * i).collect::<Vec<_>>(),
            "{par:?}"
        );
        let inits = inits.load(Ordering::Relaxed);
        assert!(inits >= 1, "{par:?}: no scratch made");
        assert!(inits < 10_000, "{par:?}: a scratch per index ({inits})");
        if par == Par::Seq {
            assert_eq!(inits, 1);
        }
    }
    assert!(Par::Rayon.map_init_collect(0, || (), |_, i| i).is_empty());
}

#[test]
fn map_chunk_pairs_mut_hands_out_matching_parts_in_order() {
    for par in [Par::Seq, Par::Rayon] {
        for chunk in [0, 1, 7, 1000, 5000] {
            let mut a = vec![0usize; 1000];
            let mut b = vec![0u8; 1000];
            // Each part writes its indices into `a`, marks `b`, and returns its range.
            let ranges = par.map_chunk_pairs_mut(&mut a, &mut b, chunk, |start, pa, pb| {
                assert_eq!(pa.len(), pb.len());
                assert!(pa.len() <= chunk.max(1));
                for (i, (x, y)) in pa.iter_mut().zip(pb.iter_mut()).enumerate() {
                    *x = start + i;
                    *y += 1;
                }
                (start, start + pa.len())
            });
            assert_eq!(a, (0..1000).collect::<Vec<_>>(), "{par:?}, chunk {chunk}");
            assert!(b.iter().all(|&y| y == 1), "{par:?}, chunk {chunk}");
            // The ranges come in order and tile 0..1000.
            let mut end = 0;
            for (s, e) in ranges {
                assert_eq!(s, end, "{par:?}, chunk {chunk}");
                end = e;
            }
            assert_eq!(end, 1000);
        }
    }
    let (mut a, mut b): (Vec<u8>, Vec<u8>) = (Vec::new(), Vec::new());
    assert!(Par::Rayon
        .map_chunk_pairs_mut(&mut a, &mut b, 4, |_, _, _| 0)
        .is_empty());
}

#[test]
fn filter_map_collect_keeps_the_kept_indices_in_order() {
    for par in [Par::Seq, Par::Rayon] {
        for chunk in [0, 1, 7, 1000, 5000] {
            // Multiples of 7 below 1000, as their squares.
            let out = par.filter_map_collect(1000, chunk, |i| (i % 7 == 0).then_some(i * i));
            let want: Vec<usize> = (0..1000).filter(|i| i % 7 == 0).map(|i| i * i).collect();
            assert_eq!(out, want, "{par:?}, chunk {chunk}");
        }
        assert!(par
            .filter_map_collect(0, 4, |_| -> Option<u8> {
                panic!("no index of an empty range")
            })
            .is_empty());
    }
}

//! The kd-tree's queries equal a brute-force search (seeded random clouds with duplicates,
//! ties and k > n) and skip non-finite points.

use gmmcalib::icp::kdtree::{KdTree, Neighbour, sq_distance};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Brute force: every finite point, sorted by (distance, index), the first `k`.
fn brute_force(points: &[[f32; 3]], q: [f64; 3], k: usize) -> Vec<Neighbour> {
    let mut all: Vec<Neighbour> = points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
        .map(|(index, p)| Neighbour { index, sq_distance: sq_distance(q, *p) })
        .collect();
    all.sort_by(|a, b| a.sq_distance.total_cmp(&b.sq_distance).then(a.index.cmp(&b.index)));
    all.truncate(k);
    all
}

/// Random cloud with clumps of exact duplicates and points snapped to a coarse grid, so
/// that ties in distance really occur.
fn random_cloud(rng: &mut Pcg64, n: usize) -> Vec<[f32; 3]> {
    let mut points = Vec::with_capacity(n);
    while points.len() < n {
        let p: [f32; 3] = std::array::from_fn(|_| rng.random_range(-5.0f32..5.0));
        match rng.random_range(0..4) {
            0 => points.push(p.map(|c| c.round())),
            1 if !points.is_empty() => {
                let i = rng.random_range(0..points.len());
                points.push(points[i]);
            }
            _ => points.push(p),
        }
    }
    points
}

#[test]
fn k_nearest_equals_brute_force() {
    let mut rng = Pcg64::seed_from_u64(7);
    for n in [0, 1, 2, 5, 8, 9, 17, 100, 1000] {
        let points = random_cloud(&mut rng, n);
        let tree = KdTree::new(&points);
        assert_eq!(tree.len(), n);
        for _ in 0..50 {
            let q: [f64; 3] = std::array::from_fn(|_| rng.random_range(-6.0..6.0));
            // Also query exactly at stored points (duplicates make ties at distance 0).
            let q = if n > 0 && rng.random_range(0..3) == 0 {
                points[rng.random_range(0..n)].map(f64::from)
            } else {
                q
            };
            for k in [1, 2, 3, 8, 20, n, n + 5] {
                assert_eq!(tree.k_nearest(q, k), brute_force(&points, q, k), "n {n} k {k}");
            }
            assert_eq!(tree.nearest(q), brute_force(&points, q, 1).first().copied());
            let within = tree.nearest_within(q, 1.5);
            let expected = brute_force(&points, q, 1).into_iter().find(|nb| nb.sq_distance <= 2.25);
            assert_eq!(within, expected);
        }
    }
}

#[test]
fn for_each_k_nearest_equals_brute_force() {
    let mut rng = Pcg64::seed_from_u64(11);
    for n in [0, 1, 3, 9, 50, 700] {
        let mut points = random_cloud(&mut rng, n);
        if n > 3 {
            points[2] = [f32::NAN, 0.0, 0.0];
        }
        let tree = KdTree::new(&points);
        for k in [1, 3, 20, n + 1] {
            let mut seen = vec![false; n];
            tree.for_each_k_nearest(k, |i, found| {
                assert!(!seen[i], "point {i} visited twice");
                seen[i] = true;
                assert_eq!(found, brute_force(&points, points[i].map(f64::from), k), "n {n} k {k}");
            });
            let finite = points.iter().filter(|p| p.iter().all(|c| c.is_finite())).count();
            assert_eq!(seen.iter().filter(|s| **s).count(), finite);
        }
    }
}

/// On a lattice every query has many neighbours at exactly its k-th distance: each search
/// starts bounded by the previous query's neighbours, and ties at that bound must still be
/// found and ordered by index.
#[test]
fn for_each_k_nearest_on_a_lattice_keeps_the_ties_at_its_bound() {
    let points: Vec<[f32; 3]> = (0..6 * 7 * 5)
        .map(|i| [(i % 6) as f32, (i / 6 % 7) as f32 * 0.5, (i / 42) as f32])
        .collect();
    let tree = KdTree::new(&points);
    for k in [2, 5, 7, 20] {
        tree.for_each_k_nearest(k, |i, found| {
            assert_eq!(found, brute_force(&points, points[i].map(f64::from), k), "k {k}");
        });
    }
}

#[test]
fn skips_non_finite_points_and_queries() {
    let points = vec![[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [f32::INFINITY; 3]];
    let tree = KdTree::new(&points);
    assert_eq!(tree.len(), 2);
    let mut order: Vec<usize> = tree.tree_order().collect();
    order.sort();
    assert_eq!(order, vec![0, 2]);
    let found = tree.k_nearest([0.9, 0.0, 0.0], 10);
    assert_eq!(found.iter().map(|n| n.index).collect::<Vec<_>>(), vec![2, 0]);
    assert!(tree.nearest([f64::NAN, 0.0, 0.0]).is_none());
    assert!(tree.k_nearest([0.0, f64::INFINITY, 0.0], 3).is_empty());
    assert!(tree.nearest_within([5.0, 0.0, 0.0], 1.0).is_none());
    assert!(KdTree::new(&[]).nearest([0.0; 3]).is_none());
}

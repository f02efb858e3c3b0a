//! Tests of the kd-tree (a child module of `kdtree`, kept in a file of its own).

use super::*;
use crate::sampling::Rng;

fn random_points(n: usize, seed: u64, duplicates: bool) -> Vec<Vec3> {
    let mut rng = Rng::for_task(seed, [0, 0, 0]);
    let mut pts: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0))
        .collect();
    if duplicates {
        // Many exact duplicates and points sharing one coordinate (ties at every split).
        for i in 0..n {
            if i % 3 == 0 {
                pts[i] = pts[i / 5];
            } else if i % 3 == 1 {
                pts[i].x = 0.5;
            }
        }
    }
    pts
}

fn brute_force(pts: &[Vec3], p: Vec3, k: usize, r: f32, keep: impl Fn(&Vec3) -> bool) -> Vec<f32> {
    let mut d: Vec<f32> = pts
        .iter()
        .filter(|q| keep(q))
        .map(|q| (*q - p).length_squared())
        .filter(|&d2| d2 <= r * r)
        .collect();
    d.sort_by(f32::total_cmp);
    d.truncate(k);
    d
}

fn check_k_nearest(pts: &[Vec3], seed: u64) {
    check_k_nearest_in(&KdTree::build(pts.to_vec()), pts, seed);
    check_k_nearest_in(&KdTree::build_for_nearest(pts.to_vec()), pts, seed);
}

fn check_k_nearest_in(tree: &KdTree<Vec3>, pts: &[Vec3], seed: u64) {
    let mut sorted_in = pts.to_vec();
    let mut sorted_tree = tree.items().to_vec();
    sorted_in.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    sorted_tree.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    assert_eq!(sorted_in, sorted_tree, "the tree holds exactly the input");
    let mut rng = Rng::for_task(seed, [1, 0, 0]);
    let mut out = Vec::new();
    for q in 0..300 {
        let p = Vec3::new(
            rng.uniform() * 1.4 - 0.2,
            rng.uniform() * 0.7 - 0.1,
            rng.uniform() * 2.4 - 0.2,
        );
        let p = if q % 10 == 0 && !pts.is_empty() {
            pts[q % pts.len()]
        } else {
            p
        };
        let k = [1usize, 2, 7, 50, 1000][q % 5];
        let r = [0.01f32, 0.1, 0.3, f32::INFINITY][q % 4];
        let filtered = q % 3 == 0;
        let keep = |v: &Vec3| !filtered || v.z > 0.7;
        tree.k_nearest_into(p, k, r, keep, &mut out);
        if let Some(first) = out.first() {
            assert!(
                out.iter().all(|n| n.dist2 <= first.dist2),
                "heap order: the farthest first"
            );
        }
        let mut got: Vec<f32> = out.iter().map(|n| n.dist2).collect();
        got.sort_unstable_by(f32::total_cmp);
        let want = brute_force(pts, p, k, r, keep);
        assert_eq!(got, want, "query {q}: k {k}, r {r}, filtered {filtered}");
        let mut idx: Vec<u32> = out.iter().map(|n| n.index).collect();
        for n in &out {
            let it = tree.items()[n.index as usize];
            assert_eq!((it - p).length_squared(), n.dist2);
            assert!(keep(&it));
        }
        idx.sort_unstable();
        idx.dedup();
        assert_eq!(idx.len(), out.len(), "no item is returned twice");
    }
}

#[test]
fn k_nearest_matches_brute_force_on_random_points() {
    for (n, seed) in [(2_000usize, 1u64), (37, 2), (7, 3), (6, 4), (100_000, 5)] {
        check_k_nearest(&random_points(n, seed, false), seed);
    }
}

#[test]
fn k_nearest_matches_brute_force_with_duplicate_points() {
    check_k_nearest(&random_points(3_000, 6, true), 6);
    check_k_nearest(&vec![Vec3::splat(0.25); 500], 7);
}

/// The search's first bound is guessed from the density of the query's leaf. Where fewer
/// than k items pass within it — a dense cluster in sparse surroundings, a filter that
/// rejects most items — it searches again (at most twice); either way the k nearest are exact:
/// points on a plane (where the guess is meant to hold) with a cluster of 40 in a 10⁻⁴ square,
/// queried in the cluster and on the plane, unfiltered and filtered (also by a filter that fewer
/// than k items pass at all). The slot form names the same items by their place in the blocks.
#[test]
fn k_nearest_is_exact_whether_the_guessed_bound_holds_or_not() {
    let mut rng = Rng::for_task(9, [0, 0, 0]);
    let mut pts: Vec<Vec3> = (0..20_000)
        .map(|_| Vec3::new(rng.uniform(), rng.uniform(), 0.0))
        .collect();
    let cluster = |rng: &mut Rng| Vec3::new(0.5 + 1e-4 * rng.uniform(), 0.5 + 1e-4 * rng.uniform(), 0.0);
    pts.extend((0..40).map(|_| cluster(&mut rng)));
    let tree = KdTree::build(pts.clone());
    let (mut out, mut slots) = (Vec::new(), Vec::new());
    for q in 0..600 {
        let p = if q % 2 == 0 {
            cluster(&mut rng)
        } else {
            Vec3::new(rng.uniform(), rng.uniform(), 0.0)
        };
        let k = [1usize, 50, 200][q % 3];
        // Four in five items rejected; none; all but the ~30 nearest the edge x = 0 rejected
        // (fewer than k pass in the whole tree: the search falls back to no guess).
        let filter = q % 4;
        let keep = |v: &Vec3| match filter {
            0 | 1 => v.x.to_bits().is_multiple_of(5),
            2 => true,
            _ => v.x < 1.5e-3,
        };
        tree.k_nearest_into(p, k, f32::INFINITY, keep, &mut out);
        let mut got: Vec<f32> = out.iter().map(|n| n.dist2).collect();
        got.sort_unstable_by(f32::total_cmp);
        assert_eq!(got, brute_force(&pts, p, k, f32::INFINITY, keep), "query {q}: k {k}");
        tree.k_nearest_slots(p, k, f32::INFINITY, &mut slots, |_, start, within| {
            (0..LANES as u32)
                .filter(|&i| within >> i & 1 == 1 && keep(&tree.items()[(start + i) as usize]))
                .fold(0, |mask, i| mask | 1 << i)
        });
        let mut by_slot: Vec<f32> = slots
            .iter()
            .map(|n| {
                let b = tree.block(n.index as usize / LANES);
                let lane = n.index as usize % LANES;
                let at = Vec3::new(b.x[lane], b.y[lane], b.z[lane]);
                assert_eq!(at.distance_squared(p), n.dist2, "a slot holds the item it reports");
                n.dist2
            })
            .collect();
        by_slot.sort_unstable_by(f32::total_cmp);
        assert_eq!(by_slot, got, "query {q}: the slot form finds the same items");
    }
}

#[test]
fn empty_and_single_point_trees() {
    let empty: KdTree<Vec3> = KdTree::build(Vec::new());
    assert!(empty.is_empty());
    assert!(empty.k_nearest(Vec3::ZERO, 5, f32::INFINITY, |_| true).is_empty());
    assert!(empty.nearest_where(Vec3::ZERO, f32::INFINITY, |_| true).is_none());
    let one = KdTree::build(vec![Vec3::new(1.0, 2.0, 3.0)]);
    let r = one.k_nearest(Vec3::ZERO, 5, f32::INFINITY, |_| true);
    assert_eq!(r, vec![Neighbour { index: 0, dist2: 14.0 }]);
    assert!(
        one.k_nearest(Vec3::ZERO, 5, 3.7, |_| true).is_empty(),
        "outside the radius"
    );
    assert_eq!(
        one.k_nearest(Vec3::ZERO, 5, 14f32.sqrt(), |_| true).len(),
        1,
        "inclusive"
    );
    assert!(one.k_nearest(Vec3::ZERO, 0, f32::INFINITY, |_| true).is_empty());
    assert!(one.k_nearest(Vec3::ZERO, 1, f32::NAN, |_| true).is_empty());
}

#[test]
fn nearest_where_matches_brute_force() {
    let pts = random_points(20_000, 8, true);
    for tree in [KdTree::build(pts.clone()), KdTree::build_for_nearest(pts.clone())] {
        check_nearest_where(&tree, &pts);
    }
}

fn check_nearest_where(tree: &KdTree<Vec3>, pts: &[Vec3]) {
    let mut rng = Rng::for_task(8, [2, 0, 0]);
    for q in 0..500 {
        let p = Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0);
        let r = [0.02f32, 0.2, f32::INFINITY][q % 3];
        // A selective predicate: about 1 point in 40 passes.
        let keep = |v: &Vec3| ((v.x * 1000.0) as u32).is_multiple_of(40);
        let got = tree.nearest_where(p, r, keep).map(|n| n.dist2);
        let want = brute_force(pts, p, 1, r, keep).first().copied();
        assert_eq!(got, want, "query {q}");
    }
    assert!(tree.nearest_where(Vec3::ZERO, f32::INFINITY, |_| false).is_none());
}

#[test]
fn for_each_within_visits_exactly_the_points_in_the_ball() {
    let pts = random_points(5_000, 9, true);
    let tree = KdTree::build(pts.clone());
    for (i, r) in [(0usize, 0.05f32), (17, 0.2), (400, 0.0)] {
        let p = pts[i];
        let mut got = Vec::new();
        tree.for_each_within(p, r, |_, d2| got.push(d2));
        got.sort_by(f32::total_cmp);
        assert_eq!(got, brute_force(&pts, p, usize::MAX, r, |_| true));
    }
}

#[test]
fn order_keys_order_as_the_floats_and_invert() {
    let mut rng = Rng::for_task(11, [0, 0, 0]);
    let special = [
        0.0f32,
        -0.0,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-45,
        -1e-45,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1.0,
        -1.0,
    ];
    let random = (0..20_000)
        .map(|_| f32::from_bits(rng.below(u32::MAX) ^ (rng.below(2) << 31)))
        .filter(|f| !f.is_nan());
    let all: Vec<f32> = special.into_iter().chain(random).collect();
    for (i, &a) in all.iter().enumerate() {
        assert_eq!(from_order_key(order_key(a)), a + 0.0, "{a}");
        let b = all[(i * 7919 + 13) % all.len()];
        assert_eq!(a >= b, order_key(a) >= order_key(b), "{a} vs {b}");
        for b in special {
            assert_eq!(a >= b, order_key(a) >= order_key(b), "{a} vs {b}");
        }
    }
}

#[test]
fn build_is_deterministic_across_thread_counts() {
    let pts = random_points(200_000, 10, true);
    let build = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| KdTree::build(pts.clone()))
    };
    let (a, b) = (build(1), build(2));
    assert_eq!(a.items(), b.items());
    assert_eq!(a.planes, b.planes);
}

/// The two-part filter: the same k nearest as brute force over `cheap && costly`, and the
/// costly test run at most once per item, only on items `cheap` passes, and never on one
/// farther than the answer's farthest (or than the radius, when fewer than k pass). Costly
/// tests that reject everything beyond a "wall" (x > 0.55), every third item, nothing, or
/// all but a handful; queries on both sides of the wall, with and without a radius, on points
/// with duplicates (ties at the boundary of every shell).
#[test]
fn k_nearest_tested_tests_only_what_the_answer_needs() {
    for (pts, seed) in [
        (random_points(5_000, 21, false), 21u64),
        (random_points(3_000, 22, true), 22),
        (vec![Vec3::splat(0.25); 300], 23),
    ] {
        let tree = KdTree::build(pts.clone());
        let mut rng = Rng::for_task(seed, [2, 0, 0]);
        let mut out = Vec::new();
        for q in 0..400 {
            let p = if q % 7 == 0 {
                pts[q % pts.len()]
            } else {
                Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0)
            };
            let k = [1usize, 8, 64, 400][q % 4];
            let r = [f32::INFINITY, 0.15, 0.4][q % 3];
            let cheap = |v: &Vec3| q % 2 == 0 || v.y < 0.4;
            let rule = q % 5;
            let costly_rule = |v: &Vec3| match rule {
                0 | 1 => v.x <= 0.55,
                2 => !v.x.to_bits().is_multiple_of(3),
                3 => true,
                _ => v.z < 0.05,
            };
            let calls = std::cell::RefCell::new(Vec::new());
            let costly = |v: &Vec3| {
                calls.borrow_mut().push(*v);
                costly_rule(v)
            };
            tree.k_nearest_tested(p, k, r, cheap, costly, &mut out);
            let want = brute_force(&pts, p, k, r, |v| cheap(v) && costly_rule(v));
            let mut got: Vec<f32> = out.iter().map(|n| n.dist2).collect();
            assert!(
                got.first().is_none_or(|&f| got.iter().all(|&d| d <= f)),
                "farthest first"
            );
            got.sort_unstable_by(f32::total_cmp);
            assert_eq!(got, want, "query {q}: k {k}, r {r}, rule {rule}");
            let limit = if want.len() == k { want[k - 1] } else { r * r };
            let calls = calls.into_inner();
            for v in &calls {
                assert!(cheap(v), "query {q}: costly test of an item cheap rejects");
                assert!((*v - p).length_squared() <= limit, "query {q}: a needless costly test");
            }
            // Each item once: as many calls as distinct items tested (duplicates are distinct
            // items at one position, so count positions with multiplicity against the input).
            let mut tested = calls.clone();
            tested.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
            let mut i = 0;
            while i < tested.len() {
                let same = tested[i..].iter().take_while(|v| **v == tested[i]).count();
                let copies = pts.iter().filter(|v| **v == tested[i]).count();
                assert!(same <= copies, "query {q}: an item tested twice");
                i += same;
            }
        }
    }
}

//! The lossy link: determinism (same seed, same fate for every datagram) and statistics (rates close to the
//! configured probabilities over many datagrams).

use xrce_bench::lossy::{Delivery, LinkConfig, LinkQueue, LossyLink, Pipe, Rng, MILLIS};

fn datagram(i: u32) -> Vec<u8> {
    let mut v = i.to_le_bytes().to_vec();
    v.extend((0..(i % 50) as u8).map(|b| b.wrapping_mul(7)));
    v
}

fn lossy(seed: u64) -> LinkConfig {
    LinkConfig {
        drop: 0.2,
        duplicate: 0.2,
        reorder: 0.2,
        corrupt: 0.05,
        jitter: MILLIS / 2,
        seed,
        ..LinkConfig::default()
    }
}

fn run(cfg: LinkConfig, n: u32) -> (Vec<Vec<Delivery>>, LossyLink) {
    let mut link = LossyLink::new(cfg);
    let out = (0..n).map(|i| link.send(&datagram(i), i64::from(i) * 100_000)).collect();
    (out, link)
}

#[test]
fn same_seed_same_fate() {
    let (a, la) = run(lossy(42), 10_000);
    let (b, lb) = run(lossy(42), 10_000);
    assert_eq!(a, b);
    assert_eq!(la.stats(), lb.stats());
}

#[test]
fn different_seed_different_fate() {
    let (a, _) = run(lossy(1), 1_000);
    let (b, _) = run(lossy(2), 1_000);
    assert_ne!(a, b);
}

#[test]
fn fixed_draws_per_datagram_keep_drops_independent_of_other_rates() {
    // Same seed, different duplication/corruption: the very same datagrams are dropped.
    let (a, _) = run(LinkConfig { duplicate: 0.0, corrupt: 0.0, ..lossy(7) }, 5_000);
    let (b, _) = run(LinkConfig { duplicate: 0.5, corrupt: 0.5, ..lossy(7) }, 5_000);
    let dropped = |v: &[Vec<Delivery>]| v.iter().map(Vec::is_empty).collect::<Vec<_>>();
    assert_eq!(dropped(&a), dropped(&b));
}

#[test]
fn rates_match_the_configuration() {
    let n = 200_000u32;
    let (_, link) = run(lossy(3), n);
    let s = link.stats();
    let rate = |x: u64, of: u64| x as f64 / of as f64;
    assert_eq!(s.sent, u64::from(n));
    assert!((rate(s.dropped, s.sent) - 0.2).abs() < 0.01, "{s:?}");
    let kept = s.sent - s.dropped;
    assert!((rate(s.duplicated, kept) - 0.2).abs() < 0.01, "{s:?}");
    assert!((rate(s.corrupted, kept) - 0.05).abs() < 0.005, "{s:?}");
    assert_eq!(s.delivered, kept + s.duplicated);
    assert!((rate(s.reordered, s.delivered) - 0.2).abs() < 0.01, "{s:?}");
    // Delivered per sent: 0.8 × 1.2.
    assert!((rate(s.delivered, s.sent) - 0.96).abs() < 0.01, "{s:?}");
}

#[test]
fn perfect_link_delivers_everything_in_order_after_the_delay() {
    let cfg = LinkConfig { delay: 3 * MILLIS, ..LinkConfig::default() };
    let mut link = LossyLink::new(cfg);
    for i in 0..1000 {
        let d = link.send(&datagram(i), i64::from(i));
        assert_eq!(d, vec![Delivery { at: i64::from(i) + 3 * MILLIS, data: datagram(i) }]);
    }
    assert_eq!(link.stats().delivered, 1000);
}

#[test]
fn corruption_flips_exactly_one_bit() {
    let cfg = LinkConfig { corrupt: 1.0, ..LinkConfig::default() };
    let mut link = LossyLink::new(cfg);
    for i in 0..1000 {
        let original = datagram(i);
        let d = link.send(&original, 0);
        assert_eq!(d.len(), 1);
        let flipped: u32 = d[0].data.iter().zip(&original).map(|(a, b)| (a ^ b).count_ones()).sum();
        assert_eq!(flipped, 1);
    }
}

#[test]
fn duplicates_carry_the_same_bytes() {
    let cfg = LinkConfig { duplicate: 1.0, corrupt: 0.3, ..LinkConfig::default() };
    let mut link = LossyLink::new(cfg);
    for i in 0..500 {
        let d = link.send(&datagram(i), 0);
        assert_eq!(d.len(), 2);
        assert_eq!(d[0].data, d[1].data);
    }
}

/// Sends `n` numbered datagrams 0.1 ms apart through a pipe and returns the numbers in delivery order.
fn delivery_order(cfg: LinkConfig, n: u32) -> Vec<u32> {
    let mut pipe = Pipe::new(cfg);
    let mut order = Vec::new();
    let mut now = 0i64;
    for i in 0..n {
        pipe.send(&i.to_le_bytes(), now);
        while let Some(d) = pipe.pop_due(now) {
            order.push(u32::from_le_bytes(d[..4].try_into().unwrap()));
        }
        now += 100_000;
    }
    now += 100 * MILLIS;
    while let Some(d) = pipe.pop_due(now) {
        order.push(u32::from_le_bytes(d[..4].try_into().unwrap()));
    }
    order
}

#[test]
fn reordering_reorders_and_nothing_else_does() {
    let plain = delivery_order(LinkConfig { delay: MILLIS, ..LinkConfig::default() }, 2000);
    assert!(plain.windows(2).all(|w| w[0] < w[1]));
    let shuffled = delivery_order(LinkConfig { reorder: 0.2, ..LinkConfig::default() }, 2000);
    let inversions = shuffled.windows(2).filter(|w| w[0] > w[1]).count();
    assert!(inversions > 100, "{inversions} inversions");
    let mut sorted = shuffled.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..2000).collect::<Vec<_>>(), "reordering loses nothing");
}

#[test]
fn queue_orders_by_time_then_fifo() {
    let mut q = LinkQueue::new();
    q.push([
        Delivery { at: 5, data: vec![1] },
        Delivery { at: 3, data: vec![2] },
        Delivery { at: 5, data: vec![3] },
        Delivery { at: 3, data: vec![4] },
    ]);
    assert_eq!(q.next_at(), Some(3));
    assert_eq!(q.pop_due(2), None);
    let got: Vec<_> = std::iter::from_fn(|| q.pop_due(10)).collect();
    assert_eq!(got, vec![vec![2], vec![4], vec![1], vec![3]]);
    assert!(q.is_empty());
}

#[test]
fn rng_is_deterministic_and_in_range() {
    let mut a = Rng::new(0);
    let mut b = Rng::new(0);
    for _ in 0..10_000 {
        assert_eq!(a.next_u64(), b.next_u64());
        let r = a.range(-3, 7);
        b.range(-3, 7);
        assert!((-3..=7).contains(&r));
        let u = a.unit();
        b.unit();
        assert!((0.0..1.0).contains(&u));
    }
    assert_eq!(Rng::new(5).range(4, 4), 4);
    assert_eq!(Rng::new(5).range(9, 4), 9);
}

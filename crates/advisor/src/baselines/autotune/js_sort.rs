//! `Array.prototype.sort` with a comparator, in the order node's V8 leaves
//! the array, also when the comparator is not a consistent order.
//!
//! oref0 sorts numbers with `function (a, b) { return a - b; }`. When one of
//! them is NaN (autotune's ratio `1 + deviation / BGI` of a reading with no
//! insulin activity, 0 / 0), the comparator answers NaN, which ECMA-262's
//! SortCompare takes as +0: "equal" to everything. That is no order at all,
//! so the result depends on the algorithm: Rust's own sort may even panic on
//! it, and any other algorithm puts the NaN elsewhere and moves the median
//! that autotune reads. This module follows V8's algorithm step by step (V8
//! 7.0 and later, node 11 on: TimSort as Tim Peters described it for
//! CPython's `listsort`, with its runs, binary insertion, merge rules and
//! galloping; V8's `third_party/v8/builtins/array-sort.tq`), written here in
//! our own code. Only the comparisons' outcomes decide the order, as in V8:
//! `less(a, b)` is "the comparator's result is below 0".

/// V8's threshold of consecutive wins before a merge gallops.
const MIN_GALLOP: usize = 7;

/// Sorts `v` in the order `v.sort((a, b) => cmp(a, b))` leaves it in node.
pub fn sort_by<T: Clone>(v: &mut [T], cmp: impl Fn(&T, &T) -> f64) {
    let less = |a: &T, b: &T| cmp(a, b) < 0.0;
    let n = v.len();
    if n < 2 {
        return;
    }
    let mut state = State {
        runs: Vec::new(),
        min_gallop: MIN_GALLOP,
    };
    let min_run = min_run_length(n);
    let mut low = 0;
    let mut remaining = n;
    while remaining != 0 {
        let mut run = count_and_make_run(v, low, low + remaining, &less);
        if run < min_run {
            let forced = min_run.min(remaining);
            binary_insertion_sort(v, low, low + run, low + forced, &less);
            run = forced;
        }
        state.runs.push((low, run));
        state.merge_collapse(v, &less);
        low += run;
        remaining -= run;
    }
    state.merge_force_collapse(v, &less);
}

/// The shortest run worth merging: `n` shifted below 64, plus one if any
/// bit shifted out was set.
fn min_run_length(mut n: usize) -> usize {
    let mut r = 0;
    while n >= 64 {
        r |= n & 1;
        n >>= 1;
    }
    n + r
}

/// The length of the run starting at `low` (ascending, or strictly
/// descending and then reversed in place).
fn count_and_make_run<T>(
    v: &mut [T],
    low: usize,
    high: usize,
    less: &impl Fn(&T, &T) -> bool,
) -> usize {
    if low + 1 == high {
        return 1;
    }
    let descending = less(&v[low + 1], &v[low]);
    let mut len = 2;
    let mut i = low + 2;
    while i < high {
        let down = less(&v[i], &v[i - 1]);
        if down != descending {
            break;
        }
        len += 1;
        i += 1;
    }
    if descending {
        v[low..low + len].reverse();
    }
    len
}

/// Sorts `v[low..high]`, whose `v[low..start]` is sorted, by inserting each
/// later element after the last one it is not less than.
fn binary_insertion_sort<T: Clone>(
    v: &mut [T],
    low: usize,
    start: usize,
    high: usize,
    less: &impl Fn(&T, &T) -> bool,
) {
    let start = if low == start { start + 1 } else { start };
    for s in start..high {
        let pivot = v[s].clone();
        let (mut left, mut right) = (low, s);
        while left < right {
            let mid = left + ((right - left) >> 1);
            if less(&pivot, &v[mid]) {
                right = mid;
            } else {
                left = mid + 1;
            }
        }
        v[left..=s].rotate_right(1);
    }
}

/// Where `key` goes in the sorted `a[base..base + len]`, before any element
/// equal to it, searched outward from `base + hint`: an offset in 0..=len.
fn gallop_left<T>(
    a: &[T],
    key: &T,
    base: usize,
    len: usize,
    hint: usize,
    less: &impl Fn(&T, &T) -> bool,
) -> usize {
    let (mut last, mut offset) = (0usize, 1usize);
    let (lo, hi);
    if less(&a[base + hint], key) {
        let max = len - hint;
        while offset < max {
            if !less(&a[base + hint + offset], key) {
                break;
            }
            last = offset;
            offset = (offset << 1) + 1;
        }
        offset = offset.min(max);
        lo = last + hint;
        hi = offset + hint;
    } else {
        let max = hint + 1;
        while offset < max {
            if less(&a[base + hint - offset], key) {
                break;
            }
            last = offset;
            offset = (offset << 1) + 1;
        }
        offset = offset.min(max);
        // hint - offset may be -1 (as in V8, before the ++ below).
        lo = (hint + 1).wrapping_sub(offset).wrapping_sub(1);
        hi = hint - last;
    }
    let (mut lo, mut hi) = (lo.wrapping_add(1), hi);
    while lo < hi {
        let m = lo + ((hi - lo) >> 1);
        if less(&a[base + m], key) {
            lo = m + 1;
        } else {
            hi = m;
        }
    }
    hi
}

/// Where `key` goes in the sorted `a[base..base + len]`, after any element
/// equal to it, searched outward from `base + hint`.
fn gallop_right<T>(
    a: &[T],
    key: &T,
    base: usize,
    len: usize,
    hint: usize,
    less: &impl Fn(&T, &T) -> bool,
) -> usize {
    let (mut last, mut offset) = (0usize, 1usize);
    let (lo, hi);
    if less(key, &a[base + hint]) {
        let max = hint + 1;
        while offset < max {
            if !less(key, &a[base + hint - offset]) {
                break;
            }
            last = offset;
            offset = (offset << 1) + 1;
        }
        offset = offset.min(max);
        lo = (hint + 1).wrapping_sub(offset).wrapping_sub(1);
        hi = hint - last;
    } else {
        let max = len - hint;
        while offset < max {
            if less(key, &a[base + hint + offset]) {
                break;
            }
            last = offset;
            offset = (offset << 1) + 1;
        }
        offset = offset.min(max);
        lo = last + hint;
        hi = offset + hint;
    }
    let (mut lo, mut hi) = (lo.wrapping_add(1), hi);
    while lo < hi {
        let m = lo + ((hi - lo) >> 1);
        if less(key, &a[base + m]) {
            hi = m;
        } else {
            lo = m + 1;
        }
    }
    hi
}

/// The pending runs (start, length) and the galloping threshold, which
/// carries over from one merge to the next as in V8.
struct State {
    runs: Vec<(usize, usize)>,
    min_gallop: usize,
}

impl State {
    fn len(&self, i: usize) -> usize {
        self.runs[i].1
    }

    /// Whether run `n` and the two below it keep TimSort's invariant.
    fn invariant(&self, n: usize) -> bool {
        n < 2 || self.len(n - 2) > self.len(n - 1) + self.len(n)
    }

    fn merge_collapse<T: Clone>(&mut self, v: &mut [T], less: &impl Fn(&T, &T) -> bool) {
        while self.runs.len() > 1 {
            let mut n = self.runs.len() - 2;
            if !self.invariant(n + 1) || !self.invariant(n) {
                if self.len(n - 1) < self.len(n + 1) {
                    n -= 1;
                }
                self.merge_at(v, n, less);
            } else if self.len(n) <= self.len(n + 1) {
                self.merge_at(v, n, less);
            } else {
                break;
            }
        }
    }

    fn merge_force_collapse<T: Clone>(&mut self, v: &mut [T], less: &impl Fn(&T, &T) -> bool) {
        while self.runs.len() > 1 {
            let mut n = self.runs.len() - 2;
            if n > 0 && self.len(n - 1) < self.len(n + 1) {
                n -= 1;
            }
            self.merge_at(v, n, less);
        }
    }

    /// Merges runs `i` and `i + 1`.
    fn merge_at<T: Clone>(&mut self, v: &mut [T], i: usize, less: &impl Fn(&T, &T) -> bool) {
        let (mut base_a, mut len_a) = self.runs[i];
        let (base_b, mut len_b) = self.runs[i + 1];
        self.runs[i].1 = len_a + len_b;
        self.runs.remove(i + 1);
        // Elements of A already in place before B's first.
        let k = gallop_right(v, &v[base_b], base_a, len_a, 0, less);
        base_a += k;
        len_a -= k;
        if len_a == 0 {
            return;
        }
        // Elements of B already in place after A's last.
        len_b = gallop_left(v, &v[base_a + len_a - 1], base_b, len_b, len_b - 1, less);
        if len_b == 0 {
            return;
        }
        if len_a <= len_b {
            self.merge_low(v, base_a, len_a, base_b, len_b, less);
        } else {
            self.merge_high(v, base_a, len_a, base_b, len_b, less);
        }
    }

    /// Merges A (copied aside) and B front to back.
    fn merge_low<T: Clone>(
        &mut self,
        v: &mut [T],
        base_a: usize,
        mut len_a: usize,
        base_b: usize,
        mut len_b: usize,
        less: &impl Fn(&T, &T) -> bool,
    ) {
        let temp: Vec<T> = v[base_a..base_a + len_a].to_vec();
        let (mut dest, mut ct, mut cb) = (base_a, 0usize, base_b);
        v[dest] = v[cb].clone();
        dest += 1;
        cb += 1;
        len_b -= 1;
        // How the merge ends: A's rest after the merged part (Succeed), or
        // B's rest and then A's last element (CopyB).
        let copy_b = 'merge: {
            if len_b == 0 {
                break 'merge false;
            }
            if len_a == 1 {
                break 'merge true;
            }
            let mut min_gallop = self.min_gallop;
            loop {
                let (mut wins_a, mut wins_b) = (0usize, 0usize);
                loop {
                    if less(&v[cb], &temp[ct]) {
                        v[dest] = v[cb].clone();
                        dest += 1;
                        cb += 1;
                        wins_b += 1;
                        wins_a = 0;
                        len_b -= 1;
                        if len_b == 0 {
                            break 'merge false;
                        }
                        if wins_b >= min_gallop {
                            break;
                        }
                    } else {
                        v[dest] = temp[ct].clone();
                        dest += 1;
                        ct += 1;
                        wins_a += 1;
                        wins_b = 0;
                        len_a -= 1;
                        if len_a == 1 {
                            break 'merge true;
                        }
                        if wins_a >= min_gallop {
                            break;
                        }
                    }
                }
                min_gallop += 1;
                let mut first = true;
                while wins_a >= MIN_GALLOP || wins_b >= MIN_GALLOP || first {
                    first = false;
                    min_gallop = min_gallop.saturating_sub(1).max(1);
                    self.min_gallop = min_gallop;
                    wins_a = gallop_right(&temp, &v[cb], ct, len_a, 0, less);
                    if wins_a > 0 {
                        v[dest..dest + wins_a].clone_from_slice(&temp[ct..ct + wins_a]);
                        dest += wins_a;
                        ct += wins_a;
                        len_a -= wins_a;
                        if len_a == 1 {
                            break 'merge true;
                        }
                        if len_a == 0 {
                            break 'merge false;
                        }
                    }
                    v[dest] = v[cb].clone();
                    dest += 1;
                    cb += 1;
                    len_b -= 1;
                    if len_b == 0 {
                        break 'merge false;
                    }
                    wins_b = gallop_left(v, &temp[ct], cb, len_b, 0, less);
                    if wins_b > 0 {
                        for j in 0..wins_b {
                            v[dest + j] = v[cb + j].clone();
                        }
                        dest += wins_b;
                        cb += wins_b;
                        len_b -= wins_b;
                        if len_b == 0 {
                            break 'merge false;
                        }
                    }
                    v[dest] = temp[ct].clone();
                    dest += 1;
                    ct += 1;
                    len_a -= 1;
                    if len_a == 1 {
                        break 'merge true;
                    }
                }
                min_gallop += 1;
                self.min_gallop = min_gallop;
            }
        };
        if copy_b {
            for j in 0..len_b {
                v[dest + j] = v[cb + j].clone();
            }
            v[dest + len_b] = temp[ct].clone();
        } else if len_a > 0 {
            v[dest..dest + len_a].clone_from_slice(&temp[ct..ct + len_a]);
        }
    }

    /// Merges A and B (copied aside) back to front.
    fn merge_high<T: Clone>(
        &mut self,
        v: &mut [T],
        base_a: usize,
        mut len_a: usize,
        base_b: usize,
        mut len_b: usize,
        less: &impl Fn(&T, &T) -> bool,
    ) {
        let temp: Vec<T> = v[base_b..base_b + len_b].to_vec();
        // Cursors one past the element they name, so that they may reach
        // the start (V8's cursors then read -1).
        let mut dest = base_b + len_b; // v[dest - 1] is the next to write
        let mut ct = len_b; // temp[ct - 1] is B's last unmerged
        let mut ca = base_a + len_a; // v[ca - 1] is A's last unmerged
        v[dest - 1] = v[ca - 1].clone();
        dest -= 1;
        ca -= 1;
        len_a -= 1;
        // How the merge ends: B's rest before the merged part (Succeed), or
        // A's rest and then B's first element (CopyA).
        let copy_a = 'merge: {
            if len_a == 0 {
                break 'merge false;
            }
            if len_b == 1 {
                break 'merge true;
            }
            let mut min_gallop = self.min_gallop;
            loop {
                let (mut wins_a, mut wins_b) = (0usize, 0usize);
                loop {
                    if less(&temp[ct - 1], &v[ca - 1]) {
                        v[dest - 1] = v[ca - 1].clone();
                        dest -= 1;
                        ca -= 1;
                        wins_a += 1;
                        wins_b = 0;
                        len_a -= 1;
                        if len_a == 0 {
                            break 'merge false;
                        }
                        if wins_a >= min_gallop {
                            break;
                        }
                    } else {
                        v[dest - 1] = temp[ct - 1].clone();
                        dest -= 1;
                        ct -= 1;
                        wins_b += 1;
                        wins_a = 0;
                        len_b -= 1;
                        if len_b == 1 {
                            break 'merge true;
                        }
                        if wins_b >= min_gallop {
                            break;
                        }
                    }
                }
                min_gallop += 1;
                let mut first = true;
                while wins_a >= MIN_GALLOP || wins_b >= MIN_GALLOP || first {
                    first = false;
                    min_gallop = min_gallop.saturating_sub(1).max(1);
                    self.min_gallop = min_gallop;
                    let k = gallop_right(v, &temp[ct - 1], base_a, len_a, len_a - 1, less);
                    wins_a = len_a - k;
                    if wins_a > 0 {
                        for j in (0..wins_a).rev() {
                            v[dest - wins_a + j] = v[ca - wins_a + j].clone();
                        }
                        dest -= wins_a;
                        ca -= wins_a;
                        len_a -= wins_a;
                        if len_a == 0 {
                            break 'merge false;
                        }
                    }
                    v[dest - 1] = temp[ct - 1].clone();
                    dest -= 1;
                    ct -= 1;
                    len_b -= 1;
                    if len_b == 1 {
                        break 'merge true;
                    }
                    let k = gallop_left(&temp, &v[ca - 1], 0, len_b, len_b - 1, less);
                    wins_b = len_b - k;
                    if wins_b > 0 {
                        v[dest - wins_b..dest].clone_from_slice(&temp[ct - wins_b..ct]);
                        dest -= wins_b;
                        ct -= wins_b;
                        len_b -= wins_b;
                        if len_b == 1 {
                            break 'merge true;
                        }
                        if len_b == 0 {
                            break 'merge false;
                        }
                    }
                    v[dest - 1] = v[ca - 1].clone();
                    dest -= 1;
                    ca -= 1;
                    len_a -= 1;
                    if len_a == 0 {
                        break 'merge false;
                    }
                }
                min_gallop += 1;
                self.min_gallop = min_gallop;
            }
        };
        if copy_a {
            for j in (0..len_a).rev() {
                v[dest - len_a + j] = v[ca - len_a + j].clone();
            }
            dest -= len_a;
            v[dest - 1] = temp[ct - 1].clone();
        } else if len_b > 0 {
            v[dest - len_b..dest].clone_from_slice(&temp[..len_b]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    /// xorshift32, as benches/autotune_oref0/v8_sort_cases.js draws.
    struct Xorshift(u32);

    impl Xorshift {
        fn next(&mut self) -> u32 {
            let mut x = self.0;
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            self.0 = x;
            x
        }
    }

    /// Element `i` of a case of kind `kind`, as the script draws it.
    fn draw(next: &mut Xorshift, kind: u32, i: usize) -> f64 {
        let r = next.next();
        let nan_every = [3, 10, 50, 1_000_000][(kind % 4) as usize];
        if r.is_multiple_of(nan_every) {
            return f64::NAN;
        }
        if r % 97 == 1 {
            return if r & 2 != 0 {
                f64::INFINITY
            } else {
                f64::NEG_INFINITY
            };
        }
        let i = i as f64;
        match kind / 4 {
            0 => f64::from((r >> 8) % 50),
            1 => f64::from((r >> 8) % 100_000) / 1000.0,
            2 => {
                if (i / 40.0).floor() % 2.0 != 0.0 {
                    1000.0 - i + f64::from(r % 5)
                } else {
                    i + f64::from(r % 5)
                }
            }
            _ => (i % 300.0) - f64::from((r >> 8) % 3),
        }
    }

    fn fnv(ids: &[u32]) -> u32 {
        let mut h: u32 = 0x811c_9dc5;
        for id in ids {
            for b in id.to_le_bytes() {
                h ^= u32::from(b);
                h = h.wrapping_mul(0x0100_0193);
            }
        }
        h
    }

    /// The order node 20 leaves each generated array in (NaN among the
    /// numbers: the comparator is no order) is ours, element for element.
    #[test]
    fn the_order_is_node_s_also_without_a_consistent_comparator() {
        let cases: Value =
            serde_json::from_str(include_str!("../../../tests/data/v8_sort_cases.json")).unwrap();
        let cases = cases["cases"].as_array().unwrap();
        assert!(cases.len() > 200);
        for c in cases {
            let seed = c["seed"].as_u64().unwrap() as u32;
            let len = c["len"].as_u64().unwrap() as usize;
            let kind = c["kind"].as_u64().unwrap() as u32;
            let mut next = Xorshift(seed.max(1));
            let mut items: Vec<(u32, f64)> = (0..len)
                .map(|i| (i as u32, draw(&mut next, kind, i)))
                .collect();
            sort_by(&mut items, |a, b| a.1 - b.1);
            let ids: Vec<u32> = items.iter().map(|x| x.0).collect();
            assert_eq!(
                u64::from(fnv(&ids)),
                c["hash"].as_u64().unwrap(),
                "seed {seed}, {len} elements, kind {kind}"
            );
        }
    }

    /// With a consistent comparator it is a stable sort.
    #[test]
    fn a_consistent_comparator_gives_the_stable_sort() {
        let mut next = Xorshift(7);
        for len in [0, 1, 2, 3, 10, 64, 65, 300, 3000] {
            let v: Vec<(u32, f64)> = (0..len).map(|i| (i, f64::from(next.next() % 40))).collect();
            let mut ours = v.clone();
            sort_by(&mut ours, |a, b| a.1 - b.1);
            let mut std = v;
            std.sort_by(|a, b| a.1.total_cmp(&b.1));
            assert_eq!(ours, std, "{len}");
        }
    }
}

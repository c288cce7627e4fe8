//! Pareto dominance, non-dominated sorting into fronts, and the crowding distance.

/// Whether an objective vector can take part in comparisons: every value finite.
pub(crate) fn is_finite(objectives: &[f64]) -> bool {
    objectives.iter().all(|v| v.is_finite())
}

/// Whether finite `a` Pareto-dominates finite `b` (minimisation): nowhere worse, somewhere
/// better.
pub(crate) fn dominates(a: &[f64], b: &[f64]) -> bool {
    let mut better_somewhere = false;
    for (x, y) in a.iter().zip(b) {
        if x > y {
            return false;
        }
        better_somewhere |= x < y;
    }
    better_somewhere
}

/// Non-dominated sorting: the indices of `objectives` grouped into fronts, best first;
/// front 0 is the non-dominated set, front k is non-dominated once fronts 0..k are
/// removed. Within a front indices ascend. Minimisation; a vector with a NaN or infinity
/// is dominated by every finite one, so such vectors make up the last front.
///
/// The fronts are those of Deb's fast non-dominated sort; they are computed by the
/// efficient non-dominated sort with binary search (ENS-BS, Zhang et al. 2015): in
/// lexicographic order no vector can dominate an earlier one, so each is placed, by a
/// binary search over the fronts built so far, in the first front none of whose members
/// dominates it. With two objectives only each front's last member needs checking
/// (O(N log N) in all); with more, near convergence (one big front) it still does a
/// fraction of the O(M N^2) comparisons of Deb's method.
pub fn fast_non_dominated_sort(objectives: &[Vec<f64>]) -> Vec<Vec<usize>> {
    let rows: Vec<&[f64]> = objectives.iter().map(Vec::as_slice).collect();
    sort_fronts(&rows)
}

pub(crate) fn sort_fronts(rows: &[&[f64]]) -> Vec<Vec<usize>> {
    let (mut finite, failed): (Vec<usize>, Vec<usize>) =
        (0..rows.len()).partition(|&i| is_finite(rows[i]));
    finite.sort_by(|&a, &b| lexicographic(rows[a], rows[b]).then(a.cmp(&b)));
    let mut fronts: Vec<Vec<usize>> = Vec::new();
    for &candidate in &finite {
        let row = rows[candidate];
        let dominated_in = |front: &Vec<usize>| {
            if row.len() == 2 {
                // In lexicographic order a 2-D front's second objective never rises, so
                // its last member dominates the candidate if any member does.
                front.last().is_some_and(|&last| dominates(rows[last], row))
            } else {
                // Members added later are lexicographically closer, so more likely to
                // dominate: scan from the end.
                front
                    .iter()
                    .rev()
                    .any(|&member| dominates(rows[member], row))
            }
        };
        // Dominated in front k implies dominated in every earlier front: binary search.
        let first_free = fronts.partition_point(|front| dominated_in(front));
        match fronts.get_mut(first_free) {
            Some(front) => front.push(candidate),
            None => fronts.push(vec![candidate]),
        }
    }
    if !failed.is_empty() {
        fronts.push(failed);
    }
    for front in &mut fronts {
        front.sort_unstable();
    }
    fronts
}

/// The NSGA-II crowding distance of each member of one front: the sum over objectives of
/// the gap between its two neighbours, divided by the objective's range in the front.
///
/// The extremes of every objective get `+inf` (so they are always kept), and so does every
/// member of a front of one or two. A repeated objective vector counts once: its copies
/// get 0, so clones are the first to go (as in pymoo). A vector with a non-finite value
/// gets 0 and is not anyone's neighbour.
pub fn crowding_distance(front: &[&[f64]]) -> Vec<f64> {
    let mut distance = vec![0.0; front.len()];
    // Finite, first-of-its-kind members take part; clones and failures stay at 0.
    let mut members: Vec<usize> = (0..front.len()).filter(|&i| is_finite(front[i])).collect();
    members.sort_by(|&a, &b| lexicographic(front[a], front[b]).then(a.cmp(&b)));
    members.dedup_by(|later, earlier| front[*later] == front[*earlier]);
    if members.len() <= 2 {
        for &i in &members {
            distance[i] = f64::INFINITY;
        }
        return distance;
    }
    let objectives = front[members[0]].len();
    let mut order = members.clone();
    // `objective` indexes each member's objectives, not `front` as the lint assumes.
    #[allow(clippy::needless_range_loop)]
    for objective in 0..objectives {
        let value = |member: usize| front[member][objective];
        order.sort_by(|&a, &b| value(a).total_cmp(&value(b)).then(a.cmp(&b)));
        let (Some(&first), Some(&last)) = (order.first(), order.last()) else {
            continue;
        };
        let range = value(last) - value(first);
        distance[first] = f64::INFINITY;
        distance[last] = f64::INFINITY;
        if range <= 0.0 {
            continue;
        }
        for window in order.windows(3) {
            distance[window[1]] += (value(window[2]) - value(window[0])) / range;
        }
    }
    distance
}

fn lexicographic(a: &[f64], b: &[f64]) -> std::cmp::Ordering {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.total_cmp(y))
        .find(|ordering| ordering.is_ne())
        .unwrap_or(std::cmp::Ordering::Equal)
}

/// Thin a front down to `keep` members by removing, one at a time, the member with the
/// smallest crowding distance and updating its neighbours' distances (the "pruning"
/// crowding of Kukkonen & Deb 2006): unlike a single sort by crowding, two close
/// neighbours are never both dropped because each made the other look crowded.
///
/// Failed (non-finite) members go first, then clones, then the pruning proper; ties go to
/// the later index. Returns the kept members' local indices, ascending, each with its
/// crowding distance in the thinned front.
pub(crate) fn prune_by_crowding(front: &[&[f64]], keep: usize) -> Vec<(usize, f64)> {
    if front.len() <= keep {
        return crowding_distance(front).into_iter().enumerate().collect();
    }
    let mut unique: Vec<usize> = (0..front.len()).filter(|&i| is_finite(front[i])).collect();
    unique.sort_by(|&a, &b| lexicographic(front[a], front[b]).then(a.cmp(&b)));
    unique.dedup_by(|later, earlier| front[*later] == front[*earlier]);
    unique.sort_unstable();
    if unique.len() <= keep {
        // Dropping failures and clones is enough: refill with clones, then failures, in
        // index order, all at crowding 0.
        let mut kept: Vec<(usize, f64)> = Vec::with_capacity(keep);
        let in_unique: Vec<bool> = {
            let mut flags = vec![false; front.len()];
            for &i in &unique {
                flags[i] = true;
            }
            flags
        };
        let distances = {
            let members: Vec<&[f64]> = unique.iter().map(|&i| front[i]).collect();
            crowding_distance(&members)
        };
        kept.extend(unique.iter().copied().zip(distances));
        let clones = (0..front.len()).filter(|&i| !in_unique[i] && is_finite(front[i]));
        let failures = (0..front.len()).filter(|&i| !is_finite(front[i]));
        for i in clones.chain(failures) {
            if kept.len() == keep {
                break;
            }
            kept.push((i, 0.0));
        }
        kept.sort_unstable_by_key(|&(i, _)| i);
        return kept;
    }

    let objectives = front[unique[0]].len();
    let n = unique.len();
    // Per objective, a doubly linked list of the live members in sorted order (positions
    // into `unique`), and the objective's range over the unique members.
    const NONE: usize = usize::MAX;
    let mut previous = vec![vec![NONE; n]; objectives];
    let mut next = vec![vec![NONE; n]; objectives];
    let mut ranges = vec![0.0; objectives];
    for objective in 0..objectives {
        let mut order: Vec<usize> = (0..n).collect();
        let value = |p: usize| front[unique[p]][objective];
        order.sort_by(|&a, &b| value(a).total_cmp(&value(b)).then(a.cmp(&b)));
        for pair in order.windows(2) {
            next[objective][pair[0]] = pair[1];
            previous[objective][pair[1]] = pair[0];
        }
        if let (Some(&low), Some(&high)) = (order.first(), order.last()) {
            ranges[objective] = value(high) - value(low);
        }
    }
    let crowding_of = |p: usize, previous: &[Vec<usize>], next: &[Vec<usize>]| -> f64 {
        let mut total = 0.0;
        for objective in 0..objectives {
            let (before, after) = (previous[objective][p], next[objective][p]);
            if before == NONE || after == NONE {
                return f64::INFINITY;
            }
            if ranges[objective] > 0.0 {
                total += (front[unique[after]][objective] - front[unique[before]][objective])
                    / ranges[objective];
            }
        }
        total
    };
    let mut crowding: Vec<f64> = (0..n).map(|p| crowding_of(p, &previous, &next)).collect();
    let mut alive = vec![true; n];
    let mut heap: std::collections::BinaryHeap<PruneCandidate> = (0..n)
        .map(|p| PruneCandidate {
            crowding: crowding[p],
            position: p,
        })
        .collect();
    let mut remaining = n;
    while remaining > keep {
        let Some(candidate) = heap.pop() else { break };
        let p = candidate.position;
        // Entries left behind by an update are stale: only the current value counts.
        if !alive[p] || candidate.crowding.to_bits() != crowding[p].to_bits() {
            continue;
        }
        alive[p] = false;
        remaining -= 1;
        let mut touched = Vec::with_capacity(2 * objectives);
        for objective in 0..objectives {
            let (before, after) = (previous[objective][p], next[objective][p]);
            if before != NONE {
                next[objective][before] = after;
                touched.push(before);
            }
            if after != NONE {
                previous[objective][after] = before;
                touched.push(after);
            }
        }
        for q in touched {
            let updated = crowding_of(q, &previous, &next);
            if updated.to_bits() != crowding[q].to_bits() {
                crowding[q] = updated;
                heap.push(PruneCandidate {
                    crowding: updated,
                    position: q,
                });
            }
        }
    }
    (0..n)
        .filter(|&p| alive[p])
        .map(|p| (unique[p], crowding[p]))
        .collect()
}

/// A heap entry for pruning: the smallest crowding pops first, and among equals the
/// latest position, so earlier members are kept.
#[derive(Debug, Clone, Copy)]
struct PruneCandidate {
    crowding: f64,
    position: usize,
}

impl PartialEq for PruneCandidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other).is_eq()
    }
}

impl Eq for PruneCandidate {}

impl PartialOrd for PruneCandidate {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for PruneCandidate {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // BinaryHeap pops the greatest: reverse the crowding order.
        other
            .crowding
            .total_cmp(&self.crowding)
            .then(self.position.cmp(&other.position))
    }
}

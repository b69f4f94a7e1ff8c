//! Independent runs (the studies' sweeps, fault studies and Monte Carlo; `kalfmu-tune`'s
//! logs) spread over the machine's cores, and `--shard K/N` so that a batch system can
//! spread them over machines. Its own crate so that a command need not depend on the
//! studies (and their Rerun recordings) to share it.

use rayon::prelude::*;

/// Which share of the runs this process does: the runs `K − 1, K − 1 + N, …`
/// (0-based) of `--shard K/N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// `K`, 1-based.
    pub index: usize,
    /// `N`.
    pub count: usize,
}

impl Shard {
    /// Every run.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// Whether run `j` (0-based) is in this shard.
    pub fn contains(&self, j: usize) -> bool {
        j % self.count == self.index - 1
    }

    /// The jobs of `jobs` in this shard, in order.
    pub fn select<T: Clone>(&self, jobs: &[T]) -> Vec<T> {
        jobs.iter().enumerate().filter(|(j, _)| self.contains(*j)).map(|(_, job)| job.clone()).collect()
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (k, n) = s.split_once('/').ok_or("expected K/N, e.g. 1/2")?;
        let index: usize = k.parse().map_err(|_| format!("shard {s}: K is not a number"))?;
        let count: usize = n.parse().map_err(|_| format!("shard {s}: N is not a number"))?;
        if count == 0 || index == 0 || index > count {
            return Err(format!("shard {s}: need 1 ≤ K ≤ N"));
        }
        Ok(Shard { index, count })
    }
}

/// Runs `work` on every job of `shard` on all cores (rayon's pool); the results come
/// back in the jobs' order, each with its job's index.
pub fn run<J: Sync, R: Send>(jobs: &[J], shard: Shard, work: impl Fn(&J) -> R + Sync) -> Vec<(usize, R)> {
    let mine: Vec<usize> = (0..jobs.len()).filter(|&j| shard.contains(j)).collect();
    // One job per task: the runs are long and unequal, so none waits behind a batch.
    mine.into_par_iter().with_max_len(1).map(|j| (j, work(&jobs[j]))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_split_the_runs_without_overlap_and_results_keep_their_order() {
        let jobs: Vec<usize> = (0..23).collect();
        let mut seen = Vec::new();
        for k in 1..=4 {
            let shard: Shard = format!("{k}/4").parse().unwrap();
            seen.extend(run(&jobs, shard, |j| j * 10));
        }
        seen.sort();
        assert_eq!(seen, jobs.iter().map(|&j| (j, j * 10)).collect::<Vec<_>>());
        let all = run(&jobs, Shard::ALL, |j| *j);
        assert!(all.windows(2).all(|w| w[0].0 < w[1].0), "in the jobs' order");
        let selected: Vec<usize> = (1..=4).flat_map(|k| Shard { index: k, count: 4 }.select(&jobs)).collect();
        assert_eq!(selected.len(), jobs.len(), "select takes the same share as run");
        assert!(Shard { index: 2, count: 4 }.select(&jobs).iter().all(|&j| j % 4 == 1), "every N-th job from the K-th");
        assert_eq!(Shard::ALL.select(&jobs), jobs);
        for bad in ["0/2", "3/2", "1/0", "x/2", "2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}

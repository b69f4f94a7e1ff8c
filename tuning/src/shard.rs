//! `--shard K/N`, as the study sweeps take it (`studies/src/shard.rs`; this crate does
//! not depend on the studies): this process does the jobs `K − 1, K − 1 + N, …` (0-based)
//! of the list, here the logs, so that a batch system can spread them over machines.

use std::str::FromStr;

/// Which share of the jobs this process does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// `K`, 1-based.
    pub index: usize,
    /// `N`.
    pub count: usize,
}

impl Shard {
    /// Every job.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// Whether job `j` (0-based) is in this shard.
    pub fn contains(&self, j: usize) -> bool {
        j % self.count == self.index - 1
    }

    /// The jobs of `jobs` in this shard, in order.
    pub fn select<T: Clone>(&self, jobs: &[T]) -> Vec<T> {
        jobs.iter().enumerate().filter(|(j, _)| self.contains(*j)).map(|(_, job)| job.clone()).collect()
    }
}

impl FromStr for Shard {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_split_the_logs_without_overlap_as_the_sweeps_do() {
        let logs: Vec<usize> = (0..23).collect();
        let mut seen = Vec::new();
        for k in 1..=4 {
            let shard: Shard = format!("{k}/4").parse().unwrap();
            let mine = shard.select(&logs);
            assert!(mine.iter().all(|&j| j % 4 == k - 1), "every N-th log from the K-th");
            seen.extend(mine);
        }
        seen.sort();
        assert_eq!(seen, logs);
        assert_eq!(Shard::ALL.select(&logs), logs);
        for bad in ["0/2", "3/2", "1/0", "x/2", "2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}

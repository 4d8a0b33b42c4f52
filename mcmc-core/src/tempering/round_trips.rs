//! Round trips: a walker's journey from the lowest level to the highest and back, the usual measure
//! of how well tempering moves information across levels.

/// Direction labels of walkers and the number of completed round trips.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RoundTrips {
    /// `Some(true)`: last extreme visited was the bottom (heading up); `Some(false)`: the top after
    /// the bottom (heading down); `None`: has not visited the bottom yet.
    heading_up: Vec<Option<bool>>,
    /// Completed bottom → top → bottom journeys per walker.
    pub per_walker: Vec<u64>,
}

impl RoundTrips {
    /// Tracker for `walkers` walkers.
    pub fn new(walkers: usize) -> Self {
        Self {
            heading_up: vec![None; walkers],
            per_walker: vec![0; walkers],
        }
    }

    /// Walker `w` is now at `level` of `levels`.
    pub fn visit(&mut self, w: usize, level: usize, levels: usize) {
        if levels < 2 {
            return;
        }
        if level == 0 {
            if self.heading_up[w] == Some(false) {
                self.per_walker[w] += 1;
            }
            self.heading_up[w] = Some(true);
        } else if level == levels - 1 && self.heading_up[w] == Some(true) {
            self.heading_up[w] = Some(false);
        }
    }

    /// Total completed round trips.
    pub fn total(&self) -> u64 {
        self.per_walker.iter().sum()
    }
}

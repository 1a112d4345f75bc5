//! A tiny bounded FIFO for outgoing frames and events: the machines never allocate, and a
//! caller that does not drain them loses the oldest entries instead of growing memory.

use heapless::Deque;

/// Up to `N` items; pushing onto a full queue drops the oldest.
#[derive(Debug)]
pub(crate) struct Ring<T, const N: usize>(Deque<T, N>);

impl<T, const N: usize> Ring<T, N> {
    pub(crate) const fn new() -> Self {
        Self(Deque::new())
    }

    pub(crate) fn push(&mut self, item: T) {
        if self.0.is_full() {
            self.0.pop_front();
        }
        // Cannot fail: there is room now.
        let _ = self.0.push_back(item);
    }

    pub(crate) fn pop(&mut self) -> Option<T> {
        self.0.pop_front()
    }

    pub(crate) fn clear(&mut self) {
        self.0.clear();
    }
}

//! A bounded memory of keys already seen, for targets that check an expensive property once per
//! distinct value instead of once per input: forgotten when it grows past a bound, so memory
//! stays flat over a long run.

use std::collections::HashSet;
use std::sync::Mutex;

static SEEN: Mutex<Option<HashSet<String>>> = Mutex::new(None);
const SEEN_MAX: usize = 4096;

/// Whether `key` is new (and records it as seen).
pub fn first_time(key: String) -> bool {
    let mut seen = SEEN.lock().unwrap_or_else(|e| e.into_inner());
    let set = seen.get_or_insert_with(HashSet::new);
    if set.contains(&key) {
        return false;
    }
    if set.len() >= SEEN_MAX {
        set.clear();
    }
    set.insert(key);
    true
}

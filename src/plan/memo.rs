//! Small caches of pure plan decisions (a replayed frame decides
//! nothing anew, and recording a frame again costs ≤ 1 µs of CPU per draw).
//! What `plan::reach` and `plan::tie_free` decide is a pure function of a
//! plan and a few inputs (the scissors, the camera, what the outputs hold),
//! so the executor keeps the last few results with all their inputs as the
//! key ([`Memo`]), and a changed input computes anew. Plans in keys are
//! small numbers ([`PlanIds`]): equal plans get equal ids, and an id is
//! never given to another plan.

use super::Plan;

/// The last `cap` results of a pure function, by their full inputs `K`,
/// most recently used first.
#[derive(Debug)]
pub struct Memo<K, V> {
    entries: Vec<(K, V)>,
    cap: usize,
    misses: u64,
}

impl<K: PartialEq, V> Memo<K, V> {
    pub fn new(cap: usize) -> Memo<K, V> {
        assert!(cap > 0, "a memo keeps at least one result");
        Memo {
            entries: Vec::new(),
            cap,
            misses: 0,
        }
    }

    /// The result for `key`: the kept one, or `compute()`, then kept (the
    /// least recently used one dropped past `cap`).
    pub fn get_or_insert_with(&mut self, key: K, compute: impl FnOnce() -> V) -> &V {
        match self.entries.iter().position(|e| e.0 == key) {
            Some(i) => {
                let e = self.entries.remove(i);
                self.entries.insert(0, e);
            }
            None => {
                self.misses += 1;
                let v = compute();
                self.entries.insert(0, (key, v));
                self.entries.truncate(self.cap);
            }
        }
        &self.entries[0].1
    }

    /// Forgets every result.
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// How many results were computed.
    #[cfg(test)]
    pub fn misses(&self) -> u64 {
        self.misses
    }
}

/// Ids of the last plans seen: a plan equal to one of them gets its id, any
/// other a new one (ids are never reused, so a key holding an id stays
/// about one plan).
#[derive(Debug)]
pub struct PlanIds {
    recent: Vec<(Plan, u64)>,
    next: u64,
    cap: usize,
}

impl PlanIds {
    pub fn new(cap: usize) -> PlanIds {
        assert!(cap > 0, "plan ids keep at least one plan");
        PlanIds {
            recent: Vec::new(),
            next: 0,
            cap,
        }
    }

    /// The id of `plan` (cloned only when it is new).
    pub fn id(&mut self, plan: &Plan) -> u64 {
        if let Some(i) = self.recent.iter().position(|p| p.0 == *plan) {
            let e = self.recent.remove(i);
            let id = e.1;
            self.recent.insert(0, e);
            return id;
        }
        let id = self.next;
        self.next += 1;
        self.recent.insert(0, (plan.clone(), id));
        self.recent.truncate(self.cap);
        id
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Step;

    fn plan(name: &str) -> Plan {
        Plan {
            algo: "t".into(),
            depth_stencils: 1,
            textures: 0,
            stencil_bits: 0,
            output_ds: 0,
            steps: vec![Step::Pass(name.into())],
        }
    }

    #[test]
    fn a_memo_computes_once_per_key_and_again_for_a_changed_input() {
        let mut m: Memo<(u64, u32), u32> = Memo::new(2);
        let mut calls = 0;
        let mut get = |m: &mut Memo<(u64, u32), u32>, k: (u64, u32)| {
            *m.get_or_insert_with(k, || {
                calls += 1;
                k.1 * 10
            })
        };
        assert_eq!(get(&mut m, (0, 1)), 10);
        assert_eq!(get(&mut m, (0, 1)), 10);
        assert_eq!(m.misses(), 1);
        // A changed input computes anew.
        assert_eq!(get(&mut m, (0, 2)), 20);
        assert_eq!(get(&mut m, (1, 2)), 20);
        assert_eq!(m.misses(), 3);
        // Two kept: (0, 1), the least recently used, was dropped.
        assert_eq!(get(&mut m, (0, 2)), 20);
        assert_eq!(m.misses(), 3);
        assert_eq!(get(&mut m, (0, 1)), 10);
        assert_eq!(m.misses(), 4);
        m.clear();
        assert_eq!(get(&mut m, (0, 1)), 10);
        assert_eq!(m.misses(), 5);
        drop(get);
        assert_eq!(calls, 5);
    }

    #[test]
    fn equal_plans_share_an_id_and_an_evicted_plan_gets_a_new_one() {
        let mut ids = PlanIds::new(2);
        let a = ids.id(&plan("a"));
        assert_eq!(ids.id(&plan("a")), a);
        let b = ids.id(&plan("b"));
        assert_ne!(a, b);
        assert_eq!(ids.id(&plan("a")), a);
        // "c" evicts "b" (least recently seen); "b" comes back with a new id.
        let c = ids.id(&plan("c"));
        let b2 = ids.id(&plan("b"));
        assert!(c != a && c != b && b2 != b && b2 != a && b2 != c);
    }
}

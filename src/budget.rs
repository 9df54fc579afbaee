//! The memory budget every layer checks its estimates against before it
//! allocates (tessellation, CST zones, products, images): over budget, the work is
//! refused at once with the estimate, the budget and the way out, instead of an
//! allocation failure (abort) or a swap storm minutes later.
//!
//! The budget is one number for the process: by default half of the smaller of
//! the physical memory and the address-space limit (`ulimit -v`), since a run
//! holds a few copies of its largest structure at once; `--memory-budget` sets it
//! ([`set`]). It is read through [`current`], so library entry points need no
//! extra parameter.

use std::sync::OnceLock;

/// A memory budget in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// The bytes that estimated plans and images may take.
    pub bytes: u64,
    /// Where it came from, for the message.
    pub source: BudgetSource,
}

/// Where a [`Budget`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BudgetSource {
    /// Half of the physical memory or of the address-space limit.
    Default,
    /// `--memory-budget`.
    Flag,
}

/// Work refused because its estimate exceeds the budget.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} would need about {} of memory, over the budget of {}{}; {fix}{}",
    human(*estimate),
    human(budget.bytes),
    match budget.source {
        BudgetSource::Default => " (half of this machine's memory or address-space limit)",
        BudgetSource::Flag => " (--memory-budget)",
    },
    match budget.source {
        BudgetSource::Default => ", or raise it with --memory-budget (e.g. --memory-budget 16G) if the machine has the memory",
        BudgetSource::Flag => ", or raise --memory-budget",
    }
)]
pub struct OverBudget {
    /// The work refused.
    pub what: String,
    /// Its estimated memory in bytes.
    pub estimate: u64,
    /// The budget it exceeds.
    pub budget: Budget,
    /// What the user can change instead.
    pub fix: String,
}

impl Budget {
    /// Refuses `estimate` bytes of `what` over the budget.
    pub fn check(
        &self,
        what: impl FnOnce() -> String,
        estimate: u64,
        fix: &str,
    ) -> Result<(), OverBudget> {
        if estimate <= self.bytes {
            return Ok(());
        }
        Err(OverBudget {
            what: what(),
            estimate,
            budget: *self,
            fix: fix.to_string(),
        })
    }
}

static BUDGET: OnceLock<Budget> = OnceLock::new();

/// Sets the process's budget (`--memory-budget`); only the first call counts,
/// before anything reads it.
pub fn set(bytes: u64) {
    let _ = BUDGET.set(Budget {
        bytes,
        source: BudgetSource::Flag,
    });
}

thread_local! {
    static SCOPED: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` with a budget of `bytes` on this thread (tests, fuzzing, and callers
/// that run several jobs side by side), whatever the process's budget is.
pub fn with<R>(bytes: u64, f: impl FnOnce() -> R) -> R {
    let prev = SCOPED.with(|s| s.replace(Some(bytes)));
    let r = f();
    SCOPED.with(|s| s.set(prev));
    r
}

/// The budget in force: [`with`]'s on this thread, else the process's.
pub fn current() -> Budget {
    if let Some(bytes) = SCOPED.with(|s| s.get()) {
        return Budget {
            bytes,
            source: BudgetSource::Flag,
        };
    }
    *BUDGET.get_or_init(|| Budget {
        bytes: default_bytes(),
        source: BudgetSource::Default,
    })
}

/// Half of min(physical memory, address-space limit); 4 GiB when neither is known.
fn default_bytes() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| proc_field(&t, "MemTotal:").map(|kib| kib.saturating_mul(1024)));
    let limit = std::fs::read_to_string("/proc/self/limits")
        .ok()
        .and_then(|t| proc_field(&t, "Max address space"));
    match (total, limit) {
        (None, None) => 4 << 30,
        (a, b) => a.unwrap_or(u64::MAX).min(b.unwrap_or(u64::MAX)) / 2,
    }
}

/// The first number after `key` on its line (`unlimited` and others: `None`).
fn proc_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    line[key.len()..].split_whitespace().next()?.parse().ok()
}

/// `"512M"`, `"2G"`, `"1.5GiB"`, `"1000000"` (bytes) → bytes.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let err = || {
        format!("'{s}' is not a memory size: give a number with an optional unit K, M, G or T (powers of 1024), e.g. 2G or 512M")
    };
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let x: f64 = num.parse().map_err(|_| err())?;
    let unit = unit.trim().to_ascii_uppercase();
    let unit = unit
        .strip_suffix("IB")
        .or(unit.strip_suffix('B'))
        .unwrap_or(&unit);
    let mult: u64 = match unit {
        "" => 1,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => return Err(err()),
    };
    let bytes = x * mult as f64;
    if !(bytes.is_finite() && (1.0..1.8e19).contains(&bytes)) {
        return Err(err());
    }
    Ok(bytes as u64)
}

/// Bytes for people: `"4.4 GiB"`.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut x = bytes as f64;
    let mut u = 0;
    while x >= 1024.0 && u + 1 < UNITS.len() {
        x /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{x:.1} {}", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sizes_and_rejects_nonsense() {
        assert_eq!(parse_size("2G").unwrap(), 2 << 30);
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert_eq!(parse_size("64kb").unwrap(), 64 << 10);
        for bad in ["", "G", "-1G", "2X", "0", "1e3", "NaN", "99999999999T"] {
            let e = parse_size(bad).unwrap_err();
            assert!(e.contains("e.g. 2G"), "{bad}: {e}");
        }
    }

    #[test]
    fn reads_proc_fields() {
        let limits =
            "Max cpu time              unlimited            unlimited            seconds\n\
                      Max address space         4294967296           4294967296           bytes\n";
        assert_eq!(proc_field(limits, "Max address space"), Some(4 << 30));
        assert_eq!(proc_field(limits, "Max cpu time"), None);
        assert_eq!(
            proc_field("MemTotal:       24684092 kB\n", "MemTotal:"),
            Some(24684092)
        );
    }

    #[test]
    fn over_budget_says_estimate_budget_and_way_out() {
        let b = Budget {
            bytes: 2 << 30,
            source: BudgetSource::Default,
        };
        assert!(b.check(|| "x".into(), 2 << 30, "fix").is_ok());
        let e = b
            .check(
                || "a sphere of 8,390,658 vertices".into(),
                5 << 30,
                "lower `segments`",
            )
            .unwrap_err()
            .to_string();
        for n in [
            "a sphere of 8,390,658 vertices",
            "5.0 GiB",
            "2.0 GiB",
            "lower `segments`",
            "--memory-budget",
        ] {
            assert!(e.contains(n), "{n}: {e}");
        }
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(human(12), "12 B");
    }
}

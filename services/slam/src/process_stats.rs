//! The service process's own resource use for `/metrics`: resident memory and open file
//! descriptors, read from Linux's `/proc/self` (absent elsewhere, and then not reported).
//! Exposed under the standard Prometheus names `process_resident_memory_bytes` and
//! `process_open_fds`.

/// What the process uses now.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProcessStats {
    /// Resident set size, bytes.
    pub resident_bytes: Option<u64>,
    /// Open file descriptors.
    pub open_fds: Option<u64>,
}

impl ProcessStats {
    /// Reads `/proc/self/status` and `/proc/self/fd` (a few µs; on every `/metrics`).
    pub fn read() -> Self {
        let resident_bytes = std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| vm_rss_bytes(&s));
        let open_fds = std::fs::read_dir("/proc/self/fd")
            .ok()
            // The directory handle itself is one of the entries.
            .map(|d| d.count().saturating_sub(1) as u64);
        Self {
            resident_bytes,
            open_fds,
        }
    }

    /// The samples in text exposition format.
    pub fn render(&self, out: &mut String) {
        if let Some(b) = self.resident_bytes {
            out.push_str(&format!(
                "# HELP process_resident_memory_bytes Resident memory size in bytes.\n\
                 # TYPE process_resident_memory_bytes gauge\nprocess_resident_memory_bytes {b}\n"
            ));
        }
        if let Some(n) = self.open_fds {
            out.push_str(&format!(
                "# HELP process_open_fds Number of open file descriptors.\n\
                 # TYPE process_open_fds gauge\nprocess_open_fds {n}\n"
            ));
        }
    }
}

/// `VmRSS:` of a `/proc/PID/status` text, in bytes.
pub fn vm_rss_bytes(status: &str) -> Option<u64> {
    status_bytes(status, "VmRSS")
}

/// A memory field (`VmRSS`, `VmHWM`, ...) of a `/proc/PID/status` text, in bytes (the file
/// gives kB); `None` when it is absent or not in kB.
pub fn status_bytes(status: &str, field: &str) -> Option<u64> {
    let line = status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))?;
    let mut words = line.split_whitespace();
    let kb: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vm_rss_is_read_in_bytes() {
        let status = "Name:\tslam-service\nVmPeak:\t  900 kB\nVmRSS:\t   45312 kB\nThreads:\t9\n";
        assert_eq!(vm_rss_bytes(status), Some(45312 * 1024));
        assert_eq!(vm_rss_bytes("Name:\tx\n"), None);
        assert_eq!(vm_rss_bytes("VmRSS:\t12 MB\n"), None);
        assert_eq!(status_bytes(status, "VmPeak"), Some(900 * 1024));
        // A field whose name another extends is not matched by the shorter name.
        assert_eq!(status_bytes("VmRSSx:\t1 kB\n", "VmRSS"), None);
    }

    #[test]
    fn this_process_is_measured_on_linux() {
        let stats = ProcessStats::read();
        if cfg!(target_os = "linux") {
            assert!(
                stats.resident_bytes.is_some_and(|b| b > 1 << 20),
                "{stats:?}"
            );
            // stdin, stdout, stderr at least.
            assert!(stats.open_fds.is_some_and(|n| n >= 3), "{stats:?}");
        }
        let mut out = String::new();
        stats.render(&mut out);
        assert!(cfg!(not(target_os = "linux")) || out.contains("process_resident_memory_bytes "));
    }
}

//! The process's peak resident memory, for the render report (Linux: `VmHWM` of
//! `/proc/self/status`; elsewhere unknown).

/// Peak resident set size in bytes since the process started, when the system reports it.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    (words.next()? == "kB").then_some(value * 1024)
}

#[cfg(test)]
mod tests {
    #[test]
    fn peak_memory_is_reported_on_linux() {
        if cfg!(target_os = "linux") {
            let peak = super::peak_resident_bytes().expect("VmHWM on Linux");
            // Between a megabyte and a terabyte: a test process, in kilobytes converted.
            assert!((1 << 20..1 << 40).contains(&peak), "{peak}");
        }
    }
}

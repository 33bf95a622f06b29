//! What machine an example runs on, for the headers of its tables and plots.

/// The CPU's model name (`model name` of `/proc/cpuinfo`), if the system reports one.
pub fn cpu_model() -> Option<String> {
    std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split(':').nth(1))
            .map(|s| s.trim().to_string())
    })
}

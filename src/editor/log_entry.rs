//! The editor's log entries: what the app and its panels (the crowd preview's background
//! jobs) report to the log panel and the status bar.

/// How serious a log entry is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogLevel {
    Info,
    Warning,
    Error,
}

/// One line of the log.
#[derive(Clone, Debug)]
pub struct LogEntry {
    pub level: LogLevel,
    pub text: String,
}

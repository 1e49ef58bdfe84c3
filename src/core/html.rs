//! Text made safe for the report's HTML, shared by every feature's report section.

/// `s` with the characters HTML gives a meaning to replaced by their entities.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

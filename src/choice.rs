//! Closed sets of named choices (a method, a directional mode, a tone curve): one lowercase
//! name per value, shared by the command line, the settings files and the window.

/// An enum whose values each have one stable name.
pub trait Choice: Copy + Eq + Send + Sync + 'static {
    /// Every value, in the order menus and help list them.
    const ALL: &'static [Self];

    /// The value's name as typed on the command line and written to JSON.
    fn name(self) -> &'static str;

    /// The value named `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|c| c.name() == name)
    }
}

//! What a command failed on, and the exit status that tells a script which: a usage error
//! (the flags, status 2, as clap's own), an input that cannot be read (the scene, an
//! environment map, a reference or an EXR to tone-map, status 3), an output that cannot be
//! written (status 4), or anything else (status 1). Ctrl-C exits with 130 (see `render`).

use raysplat::methods::MethodError;
use raysplat::scene::SceneError;

/// A command's failure; its message is printed as one line, its kind picks the exit status.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// The flags ask for something refused (a value out of range, a combination that cannot
    /// work, a render too large for this machine, a camera the scene lacks).
    #[error("{0}")]
    Usage(String),
    /// The scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Another input could not be read or does not fit (an unknown built-in scene, an
    /// environment map, a reference image, the EXR to tone-map).
    #[error("{0}")]
    Input(String),
    /// An output cannot be written (a missing or read-only folder, a name for two outputs, an
    /// unknown image format, a failed write).
    #[error("{0}")]
    Output(String),
    /// Anything else.
    #[error("{0}")]
    Failed(String),
}

impl CliError {
    /// The process's exit status for this failure (documented in the README).
    pub fn exit_status(&self) -> i32 {
        match self {
            Self::Failed(_) => 1,
            Self::Usage(_) => 2,
            Self::Scene(_) | Self::Input(_) => 3,
            Self::Output(_) => 4,
        }
    }
}

/// A method that refuses to start: every kind is a request the flags made.
impl From<MethodError> for CliError {
    fn from(e: MethodError) -> Self {
        Self::Usage(e.to_string())
    }
}

/// An untyped message from a helper: reported as is, status 1. Callers that know the kind
/// wrap it themselves (`map_err(CliError::Output)`).
impl From<String> for CliError {
    fn from(e: String) -> Self {
        Self::Failed(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_has_its_own_status_and_the_message_is_kept() {
        let scene = SceneError::Unreadable {
            file: "a.glb".into(),
            reason: "not found".into(),
        };
        let cases = [
            (CliError::Failed("x".into()), 1),
            (CliError::Usage("x".into()), 2),
            (CliError::from(scene.clone()), 3),
            (CliError::Input("x".into()), 3),
            (CliError::Output("x".into()), 4),
            (CliError::from(MethodError::EmptyView), 2),
        ];
        for (e, status) in cases {
            assert_eq!(e.exit_status(), status, "{e:?}");
        }
        assert_eq!(
            CliError::from(scene).to_string(),
            "a.glb: cannot read the file: not found"
        );
    }
}

//! The library's error type. Every error names the file (or device) it concerns and what is
//! wrong with it.

use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file is unreadable, malformed, or asks for something unsupported.
    #[error("{file}: {message}")]
    Scene { file: String, message: String },
    /// Reading or writing a file failed.
    #[error("{file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// An input image (for comparison) is unreadable, truncated or malformed.
    #[error("{file}: {message}")]
    Image { file: String, message: String },
    /// An output could not be encoded or written.
    #[error("{file}: {message}")]
    Output { file: String, message: String },
    /// No usable GPU, or the GPU failed or cannot hold the scene.
    #[error("GPU: {0}")]
    Gpu(String),
    /// A render setting is out of range.
    #[error("{0}")]
    Settings(String),
}

impl Error {
    pub fn scene(file: &Path, message: impl Into<String>) -> Error {
        Error::Scene { file: file.display().to_string(), message: message.into() }
    }

    pub fn io(file: &Path, source: std::io::Error) -> Error {
        Error::Io { file: file.display().to_string(), source }
    }

    pub fn image(file: &Path, message: impl Into<String>) -> Error {
        Error::Image { file: file.display().to_string(), message: message.into() }
    }

    pub fn output(file: &Path, message: impl Into<String>) -> Error {
        Error::Output { file: file.display().to_string(), message: message.into() }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

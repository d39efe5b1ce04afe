//! External URIs of a glTF file (buffers, images), resolved under pathlight's rule for
//! untrusted input.
//!
//! Scenes may come from anyone (a pull request in a CI job that renders and compares), so a
//! URI may only name a file inside the scene file's folder:
//!
//! * `data:` URIs (base64) are decoded in memory;
//! * any other scheme (`file:`, `http:`, …) is refused: pathlight never fetches anything;
//! * a relative reference is percent-decoded (glTF 2.0 §3.3 and RFC 3986 §2.1) and resolved
//!   against the scene's folder; absolute paths, `..` segments that climb out of the folder,
//!   and symbolic links whose target lies outside it are refused, before anything is read.
//!
//! [`LoadOptions::allow_any_path`] lifts the folder rule (not the scheme rule) for trusted
//! local work. Refusals name the element and the URI as the glTF JSON spells it; nothing of
//! an external file's content is ever quoted.

use std::path::{Component, Path, PathBuf};

use base64::Engine;

/// How a scene is loaded. The default is the rule for untrusted input.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Let external URIs name any readable file: absolute paths, `..` out of the scene's
    /// folder, symbolic links leading elsewhere. Only for scenes you trust.
    pub allow_any_path: bool,
}

/// Where an external URI's bytes come from.
#[derive(Debug, PartialEq, Eq)]
pub enum UriSource {
    /// A `data:` URI, decoded.
    Data(Vec<u8>),
    /// A file, checked against the rule; its canonical path (symbolic links resolved), which
    /// is the one to read so that the file read is the file checked.
    File(PathBuf),
}

/// Resolves `uri` relative to `scene_dir` under `options`. The error says why it was
/// refused (the caller adds the element and file).
pub fn resolve_uri(uri: &str, scene_dir: &Path, options: &LoadOptions) -> Result<UriSource, String> {
    if let Some(rest) = strip_prefix_ignore_case(uri, "data:") {
        return decode_data_uri(rest).map(UriSource::Data);
    }
    if let Some(scheme) = uri_scheme(uri) {
        let what =
            if scheme.len() == 1 { "a drive-letter path".to_string() } else { format!("scheme '{scheme}:'") };
        return Err(format!(
            "URI '{uri}' uses {what}; only relative paths and data: URIs are allowed (pathlight never fetches or opens other URIs)"
        ));
    }
    let decoded = percent_decode(uri).map_err(|m| format!("URI '{uri}': {m}"))?;
    let reference = Path::new(&decoded);
    if options.allow_any_path {
        // Trusted: whatever the path names (a relative one still starts at the scene's folder).
        return canonical_file(&scene_dir.join(reference), uri).map(UriSource::File);
    }
    let refuse = |why: &str| {
        Err(format!(
            "URI '{uri}' {why}; only files inside the scene's folder are allowed (--allow-any-path lifts this for trusted scenes)"
        ))
    };
    if reference.is_absolute() || decoded.starts_with('\\') {
        return refuse("is an absolute path");
    }
    // Lexically first, so nothing outside is even opened: `..` may not climb above the folder.
    let mut inside = PathBuf::new();
    for component in reference.components() {
        match component {
            Component::Normal(part) => inside.push(part),
            Component::CurDir => {}
            Component::ParentDir if inside.pop() => {}
            Component::ParentDir => return refuse("leaves the scene's folder through '..'"),
            Component::RootDir | Component::Prefix(_) => return refuse("is an absolute path"),
        }
    }
    if inside.as_os_str().is_empty() {
        return Err(format!("URI '{uri}' names the scene's folder itself, not a file"));
    }
    // Then through the file system: a symbolic link on the way may lead elsewhere.
    let folder = std::fs::canonicalize(scene_dir)
        .map_err(|e| format!("cannot resolve the scene's folder '{}': {e}", scene_dir.display()))?;
    let target =
        std::fs::canonicalize(folder.join(&inside)).map_err(|e| format!("cannot open '{uri}': {e}"))?;
    if !target.starts_with(&folder) {
        return refuse("leads through a symbolic link out of the scene's folder");
    }
    canonical_file(&target, uri).map(UriSource::File)
}

/// Reads what [`resolve_uri`] resolved. `what` names the element (e.g. "buffer 0").
pub fn read_uri(uri: &str, scene_dir: &Path, options: &LoadOptions) -> Result<Vec<u8>, String> {
    match resolve_uri(uri, scene_dir, options)? {
        UriSource::Data(bytes) => Ok(bytes),
        UriSource::File(path) => std::fs::read(&path).map_err(|e| format!("cannot read '{uri}': {e}")),
    }
}

/// The canonical path of an existing regular file (not a directory, device or FIFO, which
/// could block or never end).
fn canonical_file(path: &Path, uri: &str) -> Result<PathBuf, String> {
    let canonical = std::fs::canonicalize(path).map_err(|e| format!("cannot open '{uri}': {e}"))?;
    let meta = std::fs::metadata(&canonical).map_err(|e| format!("cannot open '{uri}': {e}"))?;
    if !meta.is_file() {
        return Err(format!("'{uri}' is not a regular file"));
    }
    Ok(canonical)
}

fn strip_prefix_ignore_case<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix).then(|| &s[prefix.len()..])
}

/// The scheme of an absolute URI (RFC 3986 §3.1: ALPHA *( ALPHA / DIGIT / "+" / "-" / "." )
/// followed by ':'), or `None` for a relative reference. A colon after a '/' belongs to a
/// path segment, not a scheme.
fn uri_scheme(uri: &str) -> Option<&str> {
    let colon = uri.find(':')?;
    let scheme = &uri[..colon];
    let mut chars = scheme.chars();
    let first = chars.next()?;
    (first.is_ascii_alphabetic() && chars.all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
        .then_some(scheme)
}

/// Decodes the part of a `data:` URI after `data:`; only base64 payloads are meaningful for
/// binary glTF data.
fn decode_data_uri(rest: &str) -> Result<Vec<u8>, String> {
    let (header, payload) = rest.split_once(',').ok_or("malformed data URI (no ',')")?;
    if !header.to_ascii_lowercase().ends_with(";base64") {
        return Err("only base64 data URIs are supported".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim())
        .map_err(|e| format!("invalid base64 in data URI: {e}"))
}

/// Decodes `%XX` escapes byte-wise (so no escape can split a UTF-8 character and panic). A
/// decoded NUL, or bytes that are not UTF-8, are refused: no file name contains them
/// legitimately, and a NUL would cut the path short in the operating system.
fn percent_decode(uri: &str) -> Result<String, String> {
    fn hex(b: u8) -> Option<u8> {
        (b as char).to_digit(16).map(|d| d as u8)
    }
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(hi), Some(lo)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push(hi * 16 + lo);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    if out.contains(&0) {
        return Err("contains a NUL character".into());
    }
    String::from_utf8(out).map_err(|_| "is not UTF-8 once percent-decoded".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert_eq!(percent_decode("plain.bin").unwrap(), "plain.bin");
        assert_eq!(percent_decode("end%41").unwrap(), "endA");
        assert_eq!(percent_decode("bad%2").unwrap(), "bad%2");
        assert_eq!(percent_decode("%").unwrap(), "%");
        assert_eq!(percent_decode("%é%").unwrap(), "%é%");
        assert_eq!(percent_decode("%2e%2E/x").unwrap(), "../x");
        assert!(percent_decode("a%00b").is_err());
        assert!(percent_decode("%ff").is_err());
    }

    #[test]
    fn schemes_follow_rfc_3986() {
        assert_eq!(uri_scheme("http://example.com/a.bin"), Some("http"));
        assert_eq!(uri_scheme("file:///etc/passwd"), Some("file"));
        assert_eq!(uri_scheme("C:\\a.bin"), Some("C"));
        assert_eq!(uri_scheme("svn+ssh:x"), Some("svn+ssh"));
        assert_eq!(uri_scheme("a.bin"), None);
        assert_eq!(uri_scheme("dir/a:b.bin"), None);
        assert_eq!(uri_scheme("1x:y"), None);
    }

    #[test]
    fn data_uris_decode_in_any_case() {
        let dir = Path::new(".");
        let opts = LoadOptions::default();
        assert_eq!(
            resolve_uri("data:application/octet-stream;base64,AAEC", dir, &opts),
            Ok(UriSource::Data(vec![0, 1, 2]))
        );
        assert_eq!(
            resolve_uri("DATA:application/gltf-buffer;BASE64,AAEC", dir, &opts),
            Ok(UriSource::Data(vec![0, 1, 2]))
        );
        assert!(resolve_uri("data:text/plain,hello", dir, &opts).is_err());
    }
}

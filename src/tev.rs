//! Streaming to the tev HDR viewer (<https://github.com/Tom94/tev>) over its TCP protocol,
//! so a render on a remote machine can be watched converging (`render --tev`).
//!
//! The protocol, as tev's `src/Ipc.cpp` reads it: each packet is a little-endian `u32` of
//! its whole length (these four bytes included), a one-byte type, then the payload; `bool`
//! is one byte, strings are NUL-terminated, integers and floats little-endian. pathlight
//! sends
//!
//! * `CreateImage` (4): grab focus, name, width, height (`i32`), channel count (`i32`), the
//!   channel names;
//! * `UpdateImageV3` (6): grab focus, name, channel count, the channel names, x, y, width,
//!   height (`i32`), per-channel offsets and strides (`i64`) into the float data, the data;
//! * `CloseImage` (2): name — not sent on completion: the finished image stays open in tev.
//!
//! Channels are `R`, `G`, `B` (the mean) and `variance.R`, `variance.G`, `variance.B` (the
//! variance of the mean, as in pathlight's EXR), interleaved per pixel.

use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::film::Film;

/// tev's default port on this machine.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:14158";

/// The image name tev shows for a render of `scene`: its file name.
pub fn image_name(scene: &std::path::Path) -> String {
    format!("pathlight: {}", scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
}

/// The channels pathlight sends, in the order of the interleaved data.
pub const CHANNELS: [&str; 6] = ["R", "G", "B", "variance.R", "variance.G", "variance.B"];

pub const PACKET_CLOSE_IMAGE: u8 = 2;
pub const PACKET_CREATE_IMAGE: u8 = 4;
pub const PACKET_UPDATE_IMAGE_V3: u8 = 6;

/// Bounds connecting and each write, so a tev that stops reading cannot stall a render.
const NETWORK_TIMEOUT: Duration = Duration::from_secs(5);

/// A packet under construction: the length is filled in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        let mut bytes = vec![0u8; 4];
        bytes.push(kind);
        Packet(bytes)
    }
    fn bool(&mut self, v: bool) -> &mut Self {
        self.0.push(v as u8);
        self
    }
    fn string(&mut self, s: &str) -> &mut Self {
        // A NUL inside would end the string early on tev's side.
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn finish(&mut self) -> Vec<u8> {
        let len = self.0.len() as u32;
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        std::mem::take(&mut self.0)
    }
}

/// `CreateImage` for an image of `CHANNELS`.
pub fn create_image_packet(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut p = Packet::new(PACKET_CREATE_IMAGE);
    p.bool(true).string(name).i32(width as i32).i32(height as i32).i32(CHANNELS.len() as i32);
    for c in CHANNELS {
        p.string(c);
    }
    p.finish()
}

/// `UpdateImageV3` carrying the whole film: mean and variance of the mean per pixel.
pub fn update_image_packet(name: &str, film: &Film) -> Vec<u8> {
    let n = CHANNELS.len();
    let mut p = Packet::new(PACKET_UPDATE_IMAGE_V3);
    p.bool(false).string(name).i32(n as i32);
    for c in CHANNELS {
        p.string(c);
    }
    p.i32(0).i32(0).i32(film.width as i32).i32(film.height as i32);
    for c in 0..n {
        p.i64(c as i64);
    }
    for _ in 0..n {
        p.i64(n as i64);
    }
    let means = film.mean();
    let variances = film.variance_of_mean();
    p.0.reserve(means.len() * n * 4);
    for (m, v) in means.iter().zip(&variances) {
        for x in [m.x, m.y, m.z, v.x, v.y, v.z] {
            p.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    p.finish()
}

/// `CloseImage`.
pub fn close_image_packet(name: &str) -> Vec<u8> {
    let mut p = Packet::new(PACKET_CLOSE_IMAGE);
    p.string(name);
    p.finish()
}

/// A connection to tev showing one image.
pub struct TevStream {
    stream: TcpStream,
    name: String,
}

impl TevStream {
    /// Connects to tev at `address` (HOST:PORT) and creates the image `name`.
    pub fn connect(address: &str, name: &str, width: u32, height: u32) -> Result<TevStream, String> {
        let addr = address
            .to_socket_addrs()
            .map_err(|e| format!("{address}: not a HOST:PORT address ({e})"))?
            .next()
            .ok_or_else(|| format!("{address}: the host has no address"))?;
        let stream = TcpStream::connect_timeout(&addr, NETWORK_TIMEOUT)
            .map_err(|e| format!("cannot reach tev at {address} ({e}); is tev running?"))?;
        let _ = stream.set_write_timeout(Some(NETWORK_TIMEOUT));
        let _ = stream.set_nodelay(true);
        let mut t = TevStream { stream, name: name.to_string() };
        t.send(&create_image_packet(name, width, height))?;
        Ok(t)
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.stream.write_all(bytes).map_err(|e| format!("sending to tev failed ({e})"))
    }

    /// Sends the film as it is now.
    pub fn update(&mut self, film: &Film) -> Result<(), String> {
        self.send(&update_image_packet(&self.name, film))
    }

    /// Closes the image in tev (a render leaves it open instead; see the module comment).
    pub fn close_image(&mut self) -> Result<(), String> {
        self.send(&close_image_packet(&self.name))
    }
}

impl Drop for TevStream {
    /// Ends the connection cleanly: everything sent is flushed before the socket closes.
    fn drop(&mut self) {
        let _ = self.stream.flush();
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
    }
}

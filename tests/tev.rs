//! `render --tev` against an in-test TCP listener speaking tev's side of the protocol: the
//! packets are decoded as tev's `src/Ipc.cpp` reads them, and the last image update must
//! equal the EXR the render writes (issue 10).

mod common;

use std::io::Read;
use std::net::TcpListener;
use std::process::Command;

/// A reader over one packet's payload, in tev's encoding.
struct Payload<'a>(&'a [u8]);

impl Payload<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn string(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("NUL-terminated string");
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
    fn i32(&mut self) -> i32 {
        let v = i32::from_le_bytes(self.0[..4].try_into().unwrap());
        self.0 = &self.0[4..];
        v
    }
    fn i64(&mut self) -> i64 {
        let v = i64::from_le_bytes(self.0[..8].try_into().unwrap());
        self.0 = &self.0[8..];
        v
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.i32() as u32)
    }
}

/// Splits a byte stream into packets: (type, payload after the type byte).
fn packets(bytes: &[u8]) -> Vec<(u8, Vec<u8>)> {
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        assert!(rest.len() >= 5, "a truncated packet header");
        let len = u32::from_le_bytes(rest[..4].try_into().unwrap()) as usize;
        assert!(len >= 5 && len <= rest.len(), "packet length {len} with {} bytes left", rest.len());
        out.push((rest[4], rest[5..len].to_vec()));
        rest = &rest[len..];
    }
    out
}

#[test]
fn render_streams_create_and_updates_that_equal_the_render() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        let (mut socket, _) = listener.accept().unwrap();
        let mut bytes = Vec::new();
        socket.read_to_end(&mut bytes).unwrap();
        bytes
    });
    let dir = std::env::temp_dir().join(format!("pathlight-tev-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exr = dir.join("out.exr");
    let (width, height) = (24u32, 16u32);
    let output = Command::new(env!("CARGO_BIN_EXE_pathlight"))
        .env("XDG_RUNTIME_DIR", "/tmp")
        .args(["render", common::scene("cornell-box.gltf").to_str().unwrap(), "--backend", "cpu"])
        .args(["--spp", "8", "--width", &width.to_string(), "--height", &height.to_string()])
        .args(["--tev", &address, "-o", exr.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let bytes = server.join().unwrap();
    let packets = packets(&bytes);
    assert!(packets.len() >= 2, "a create and at least one update, got {} packets", packets.len());

    // CreateImage: grab focus, name, width, height, channel count, channel names.
    let (kind, payload) = &packets[0];
    assert_eq!(*kind, 4, "the first packet creates the image");
    let mut p = Payload(payload);
    let _grab_focus = p.u8();
    let name = p.string();
    assert_eq!(name, "pathlight: cornell-box.gltf");
    assert_eq!((p.i32(), p.i32()), (width as i32, height as i32));
    let n = p.i32();
    let channels: Vec<String> = (0..n).map(|_| p.string()).collect();
    assert_eq!(channels, ["R", "G", "B", "variance.R", "variance.G", "variance.B"]);
    assert!(p.0.is_empty(), "nothing after the channel names");

    // Every later packet is an UpdateImageV3 of the whole image; the last one holds the
    // final film, which must equal the EXR bit for bit.
    let mut last = None;
    for (kind, payload) in &packets[1..] {
        assert_eq!(*kind, 6, "updates are UpdateImageV3");
        let mut p = Payload(payload);
        let _grab_focus = p.u8();
        assert_eq!(p.string(), name);
        let n = p.i32() as usize;
        let names: Vec<String> = (0..n).map(|_| p.string()).collect();
        assert_eq!(names, channels);
        assert_eq!([p.i32(), p.i32(), p.i32(), p.i32()], [0, 0, width as i32, height as i32]);
        let offsets: Vec<i64> = (0..n).map(|_| p.i64()).collect();
        let strides: Vec<i64> = (0..n).map(|_| p.i64()).collect();
        assert_eq!(offsets, (0..n as i64).collect::<Vec<_>>());
        assert_eq!(strides, vec![n as i64; n]);
        let pixels = (width * height) as usize;
        assert_eq!(p.0.len(), pixels * n * 4, "exactly the image's floats");
        let data: Vec<f32> = (0..pixels * n).map(|_| p.f32()).collect();
        last = Some(data);
    }
    let data = last.unwrap();
    let image = pathlight::film::read_exr(&exr).unwrap();
    for (c, channel) in channels.iter().enumerate() {
        let expected = &image.channels[channel];
        for (i, e) in expected.iter().enumerate() {
            assert_eq!(data[i * n as usize + c].to_bits(), e.to_bits(), "{channel} of pixel {i}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_tev_that_is_not_running_is_a_warning_not_a_failure() {
    // Bind and drop a listener: its port is then (almost certainly) closed.
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let dir = std::env::temp_dir().join(format!("pathlight-tev-absent-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("out.png");
    let output = Command::new(env!("CARGO_BIN_EXE_pathlight"))
        .env("XDG_RUNTIME_DIR", "/tmp")
        .args(["render", common::scene("cornell-box.gltf").to_str().unwrap(), "--backend", "cpu"])
        .args(["--spp", "1", "--width", "8", "--height", "8"])
        .args(["--tev", &format!("127.0.0.1:{port}"), "-o", png.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("warning: --tev"), "{stderr}");
    assert!(png.exists(), "the render was written");
    let _ = std::fs::remove_dir_all(&dir);
}

//! Tiles PNG renders into one contact sheet: `cargo run --example contact_sheet -- OUT.png
//! COLUMNS IN1.png IN2.png …` (all inputs the same size, 8-bit RGB). Used by
//! scenes/gallery.sh for the README's picture.

use std::io::BufWriter;

fn read_rgb(path: &str) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).expect(path)));
    let mut reader = decoder.read_info().expect(path);
    let mut buf = vec![0; reader.output_buffer_size().expect(path)];
    let info = reader.next_frame(&mut buf).expect(path);
    assert_eq!(info.color_type, png::ColorType::Rgb, "{path}: expected RGB");
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, columns, inputs) = (&args[0], args[1].parse::<u32>().expect("COLUMNS"), &args[2..]);
    let images: Vec<_> = inputs.iter().map(|p| read_rgb(p)).collect();
    let (w, h) = (images[0].0, images[0].1);
    let gap = 4;
    let rows = (images.len() as u32).div_ceil(columns);
    let (sheet_w, sheet_h) = (columns * (w + gap) + gap, rows * (h + gap) + gap);
    let mut sheet = vec![24u8; (sheet_w * sheet_h * 3) as usize];
    for (k, (iw, ih, data)) in images.iter().enumerate() {
        assert_eq!((*iw, *ih), (w, h), "{}: every input must be {w}×{h}", inputs[k]);
        let (x0, y0) = (gap + (k as u32 % columns) * (w + gap), gap + (k as u32 / columns) * (h + gap));
        for y in 0..h {
            let src = (y * w * 3) as usize;
            let dst = (((y0 + y) * sheet_w + x0) * 3) as usize;
            sheet[dst..dst + (w * 3) as usize].copy_from_slice(&data[src..src + (w * 3) as usize]);
        }
    }
    let mut encoder =
        png::Encoder::new(BufWriter::new(std::fs::File::create(out).expect(out)), sheet_w, sheet_h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().unwrap().write_image_data(&sheet).unwrap();
}

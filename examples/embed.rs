//! Embedding pathlight in a Rust program through the session API: open a scene, render in
//! progressive passes while reporting progress and the predicted error, stop early once the
//! image is good enough, and write EXR and PNG.
//!
//!   cargo run --release --example embed [-- SCENE.gltf]

use std::sync::atomic::AtomicBool;

use pathlight::film::{predicted_relmse, LinearImage, Tonemap};
use pathlight::session::{BackendChoice, Session, SessionOptions};

fn main() -> Result<(), pathlight::Error> {
    let scene = std::env::args().nth(1).unwrap_or_else(|| "scenes/cornell-box.gltf".into());
    let options = SessionOptions {
        width: Some(256),
        height: Some(256),
        spp: 256,
        backend: BackendChoice::Auto,
        ..SessionOptions::new(scene)
    };
    let mut session = Session::open(&options)?;
    println!("{}", session.describe());
    if let Some(note) = &session.backend_note {
        println!("{note}");
    }
    let stop = AtomicBool::new(false);
    let stats = session.render_to(options.spp, &stop, |backend, done| {
        let predicted = predicted_relmse(&LinearImage::from_film(&backend.film()?)).unwrap_or(f64::NAN);
        println!("{done:>4} spp, predicted relMSE {predicted:.5}");
        // Good enough: stop before the full sample count.
        Ok(predicted < 1e-3)
    })?;
    println!("{} spp in {:.2} s on {}", stats.spp, stats.seconds, session.backend_name());
    let out = std::env::temp_dir();
    session.write(&[out.join("embed.exr"), out.join("embed.png")], Tonemap::Aces, 0.0)?;
    println!("wrote {}", out.join("embed.{exr,png}").display());
    Ok(())
}

//! Twin of the `shade` entry point: every pixel of the frame, rows in parallel, through the
//! kernel's `shade_pixel`.

use rayon::prelude::*;
use tileraster_core::Raster;
use tileraster_kernels::abi::{FrameParams, ShadeParams, TriangleSetup, TriangleShading};
use tileraster_kernels::programs::shade::shade_pixel;

pub fn shade(frame: &FrameParams, params: &ShadeParams, setups: &[TriangleSetup], shading: &[TriangleShading], raster: &mut Raster) {
    let stride = raster.window.width as usize;
    let (x0, y0) = (raster.window.x0, raster.window.y0);
    let owners = raster.owner.as_deref().expect("the render pipeline writes the owner layer");
    let depths = &raster.values;
    let (Some(colours), Some(faces)) = (raster.colours.as_deref_mut(), raster.faces.as_deref_mut()) else {
        panic!("the render pipeline's raster has colour and face layers")
    };
    let first_row = (frame.win_y0 - y0) as usize;
    let columns = (frame.win_x0 - x0) as usize..(frame.win_x0 - x0 + frame.win_w) as usize;
    colours
        .par_chunks_mut(stride)
        .zip(faces.par_chunks_mut(stride))
        .enumerate()
        .skip(first_row)
        .take(frame.win_h as usize)
        .for_each(|(row, (colour_row, face_row))| {
            let j = (y0 as usize + row) as i32;
            for x in columns.clone() {
                let k = row * stride + x;
                let out = shade_pixel(params, setups, shading, owners[k], depths[k].to_bits(), (x0 as usize + x) as i32, j);
                colour_row[x] = out.colour;
                face_row[x] = out.face;
            }
        });
}

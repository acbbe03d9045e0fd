//! A small software rasterizer for the report's pictures of the character: orthographic
//! front view (x right, y up), a z-buffer, flat two-sided Lambert shading, PNG out. A
//! skeleton (bones, no triangles) is drawn as round-capped sticks, and a rig that gives
//! only points as dots, so that no picture is empty.

/// What the pictures draw of a rig's vertices.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shape {
    /// Triangles (a mesh).
    pub triangles: Vec<[u32; 3]>,
    /// Bones (a skeleton), drawn where there are no triangles.
    pub bones: Vec<[u32; 2]>,
}

impl Shape {
    /// The shape of `rig`.
    pub fn of(rig: &dyn reprise_rig::Rig) -> Self {
        Self { triangles: rig.triangles().to_vec(), bones: rig.bones() }
    }

    /// How the pictures draw it, for captions.
    pub fn drawn_as(&self) -> &'static str {
        match (self.triangles.is_empty(), self.bones.is_empty()) {
            (false, _) => "the mesh",
            (true, false) => "the skeleton's bones as sticks (the rig has no triangles)",
            (true, true) => "the rig's points as dots (it gives neither triangles nor bones)",
        }
    }
}

/// A fixed camera: the box of world x–y mapped to the image, with a margin.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    lo: [f64; 2],
    scale: f64,
    w: usize,
    h: usize,
}

impl Camera {
    /// Frames every vertex of the meshes `sets` (each `x y z …`) in a `w × h` image.
    pub fn fit(sets: &[&[f64]], w: usize, h: usize) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for s in sets {
            for v in s.chunks_exact(3) {
                for a in 0..2 {
                    lo[a] = lo[a].min(v[a]);
                    hi[a] = hi[a].max(v[a]);
                }
            }
        }
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-12);
        let scale = 0.9 * (w.min(h) as f64) / span;
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let lo = [centre[0] - w as f64 / (2.0 * scale), centre[1] - h as f64 / (2.0 * scale)];
        Self { lo, scale, w, h }
    }

    /// Image width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.w, self.h)
    }

    fn project(&self, v: &[f64]) -> [f64; 3] {
        [(v[0] - self.lo[0]) * self.scale, self.h as f64 - (v[1] - self.lo[1]) * self.scale, v[2]]
    }
}

/// RGB pixels (row-major, `w × h × 3`) of `vertices` drawn as `shape`: its triangles, else
/// its bones as sticks, else every vertex as a dot.
pub fn render(cam: &Camera, vertices: &[f64], shape: &Shape, tint: [f64; 3]) -> Vec<u8> {
    let (w, h) = (cam.w, cam.h);
    let mut rgb = vec![245u8; w * h * 3];
    let mut depth = vec![f64::NEG_INFINITY; w * h];
    let p: Vec<[f64; 3]> = vertices.chunks_exact(3).map(|v| cam.project(v)).collect();
    if shape.triangles.is_empty() {
        let dots: Vec<[u32; 2]>;
        let segments = if shape.bones.is_empty() {
            dots = (0..p.len() as u32).map(|i| [i, i]).collect();
            &dots
        } else {
            &shape.bones
        };
        let radius = (0.012 * w.min(h) as f64).max(1.5);
        for &[a, b] in segments {
            let (Some(pa), Some(pb)) = (p.get(a as usize), p.get(b as usize)) else { continue };
            stick(&mut rgb, &mut depth, (w, h), (*pa, *pb), radius, tint);
        }
        return rgb;
    }
    let triangles = &shape.triangles;
    let light = {
        let l: [f64; 3] = [0.3, 0.5, 1.0];
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        [l[0] / n, l[1] / n, l[2] / n]
    };
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        if a >= p.len() || b >= p.len() || c >= p.len() {
            continue;
        }
        let (va, vb, vc) = (&vertices[3 * a..3 * a + 3], &vertices[3 * b..3 * b + 3], &vertices[3 * c..3 * c + 3]);
        let (e1, e2) = ([vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]], [vc[0] - va[0], vc[1] - va[1], vc[2] - va[2]]);
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len == 0.0 {
            continue;
        }
        let shade = 0.25 + 0.75 * ((n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / len).abs();
        let colour = tint.map(|c| (c * shade * 255.0).clamp(0.0, 255.0) as u8);
        let (pa, pb, pc) = (p[a], p[b], p[c]);
        let area = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = pa[0].min(pb[0]).min(pc[0]).floor().max(0.0) as usize;
        let x1 = (pa[0].max(pb[0]).max(pc[0]).ceil() as usize).min(w.saturating_sub(1));
        let y0 = pa[1].min(pb[1]).min(pc[1]).floor().max(0.0) as usize;
        let y1 = (pa[1].max(pb[1]).max(pc[1]).ceil() as usize).min(h.saturating_sub(1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let w0 = ((pb[0] - px) * (pc[1] - py) - (pb[1] - py) * (pc[0] - px)) / area;
                let w1 = ((pc[0] - px) * (pa[1] - py) - (pc[1] - py) * (pa[0] - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * pa[2] + w1 * pb[2] + w2 * pc[2];
                let i = y * w + x;
                if z > depth[i] {
                    depth[i] = z;
                    rgb[3 * i..3 * i + 3].copy_from_slice(&colour);
                }
            }
        }
    }
    rgb
}

/// Draws the segment `pa`–`pb` (pixels, with depth) as a round-capped stick of `radius`
/// pixels, shaded brighter along its axis, depth-tested.
fn stick(
    rgb: &mut [u8],
    depth: &mut [f64],
    (w, h): (usize, usize),
    (pa, pb): ([f64; 3], [f64; 3]),
    radius: f64,
    tint: [f64; 3],
) {
    let (dx, dy) = (pb[0] - pa[0], pb[1] - pa[1]);
    let len2 = dx * dx + dy * dy;
    let x0 = (pa[0].min(pb[0]) - radius).floor().max(0.0) as usize;
    let x1 = ((pa[0].max(pb[0]) + radius).ceil().max(0.0) as usize).min(w.saturating_sub(1));
    let y0 = (pa[1].min(pb[1]) - radius).floor().max(0.0) as usize;
    let y1 = ((pa[1].max(pb[1]) + radius).ceil().max(0.0) as usize).min(h.saturating_sub(1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let t = if len2 > 0.0 { (((px - pa[0]) * dx + (py - pa[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let (cx, cy) = (pa[0] + t * dx, pa[1] + t * dy);
            let dist = ((px - cx).powi(2) + (py - cy).powi(2)).sqrt();
            if dist > radius {
                continue;
            }
            let z = pa[2] + t * (pb[2] - pa[2]);
            let i = y * w + x;
            if z > depth[i] {
                depth[i] = z;
                let shade = 0.45 + 0.55 * (1.0 - (dist / radius).powi(2)).sqrt();
                let colour = tint.map(|c| (c * shade * 255.0).clamp(0.0, 255.0) as u8);
                rgb[3 * i..3 * i + 3].copy_from_slice(&colour);
            }
        }
    }
}

/// A PNG of RGB pixels.
pub fn png(rgb: &[u8], w: usize, h: usize) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().expect("PNG header to memory");
        writer.write_image_data(rgb).expect("PNG data to memory");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square facing the camera fills the middle of the image, the corners stay
    /// background, and the PNG has its signature.
    #[test]
    fn renders_a_square_with_a_depth_test() {
        let front = [-1.0, -1.0, 1.0, 1.0, -1.0, 1.0, 1.0, 1.0, 1.0, -1.0, 1.0, 1.0];
        let shape = Shape { triangles: vec![[0u32, 1, 2], [0, 2, 3]], bones: vec![] };
        let cam = Camera::fit(&[&front], 40, 40);
        let img = render(&cam, &front, &shape, [1.0, 0.0, 0.0]);
        let at = |x: usize, y: usize| &img[3 * (y * 40 + x)..3 * (y * 40 + x) + 3];
        assert!(at(20, 20)[0] > 100 && at(20, 20)[1] == 0, "{:?}", at(20, 20));
        assert_eq!(at(0, 0), &[245, 245, 245]);
        assert!(png(&img, 40, 40).starts_with(&[0x89, b'P', b'N', b'G']));
    }

    /// A skeleton is drawn as sticks along its bones (pixels on a bone coloured, far from
    /// every bone background); a rig of bare points as dots; the captions say which.
    #[test]
    fn skeletons_and_points_are_drawn() {
        // An L: hip (0,0) – knee (0,-1) – foot (1,-1).
        let joints = [0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, -1.0, 0.0];
        let cam = Camera::fit(&[&joints], 60, 60);
        let bones = Shape { triangles: vec![], bones: vec![[0, 1], [1, 2]] };
        let img = render(&cam, &joints, &bones, [0.0, 0.0, 1.0]);
        let px = |v: [f64; 3]| {
            let p = cam.project(&v);
            let i = 3 * ((p[1] as usize).min(59) * 60 + (p[0] as usize).min(59));
            [img[i], img[i + 1], img[i + 2]]
        };
        assert!(px([0.0, -0.5, 0.0])[2] > 100, "on the thigh");
        assert!(px([0.5, -1.0, 0.0])[2] > 100, "on the shin");
        assert_eq!(px([0.6, -0.3, 0.0]), [245, 245, 245], "between the bones");
        let dots = render(&cam, &joints, &Shape::default(), [0.0, 0.0, 1.0]);
        assert!(dots.chunks(3).filter(|c| c[2] > 100 && c[0] == 0).count() >= 3 * 4, "three dots");
        assert!(dots.chunks(3).filter(|c| c == &[245, 245, 245]).count() > 60 * 60 * 9 / 10);
        assert!(bones.drawn_as().contains("sticks") && Shape::default().drawn_as().contains("dots"));
    }
}

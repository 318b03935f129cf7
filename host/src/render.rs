//! A small software rasteriser for looking at meshes: flat-shaded triangles with a
//! z-buffer, optional wireframe and point overlays, PNG output.
//!
//! The camera looks at the bounding box from one of four views and is fitted so the
//! model fills the image with a margin. Faces seen from the front are light blue-grey,
//! faces seen from the back amber, so holes (the inside shows through) and flipped faces
//! stand out. Shading is Lambert plus ambient from a light fixed to the camera (above,
//! left, in front). Rendering happens at `supersample`² samples per pixel, box-filtered
//! down: cost O(F + covered samples), memory 16 bytes per sample. Deterministic: the
//! same input and options give identical pixels.

use crate::geom::{cross, dot, sub};
use crate::io::{write_atomic, WriteError};
use std::fmt;
use std::io;
use std::path::Path;

/// An RGB8 image, rows top to bottom, 3 bytes per pixel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` bytes.
    pub pixels: Vec<u8>,
}

impl Image {
    /// A `width` x `height` image filled with `colour`.
    pub fn filled(width: u32, height: u32, colour: [u8; 3]) -> Image {
        let n = width as usize * height as usize;
        Image {
            width,
            height,
            pixels: colour.repeat(n),
        }
    }

    /// The pixel at column `x`, row `y` (0, 0 is the top left).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
    }

    fn put(&mut self, x: u32, y: u32, c: [u8; 3]) {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        self.pixels[i..i + 3].copy_from_slice(&c);
    }
}

/// Where the camera looks from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum View {
    /// From the front.
    Front,
    /// From the right-hand side.
    Side,
    /// From above, the front at the bottom of the image.
    Top,
    /// Three-quarter view from the front, right and above.
    #[default]
    Iso,
}

impl View {
    /// Parses `front`, `side`, `top` or `iso`.
    pub fn from_name(s: &str) -> Option<View> {
        Some(match s {
            "front" => View::Front,
            "side" => View::Side,
            "top" => View::Top,
            "iso" => View::Iso,
            _ => return None,
        })
    }
}

/// The model's up direction: a coordinate axis (0 = x, 1 = y, 2 = z), maybe negated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Up {
    /// 0, 1 or 2.
    pub axis: usize,
    /// Up is the negative axis.
    pub negative: bool,
}

impl Default for Up {
    /// +y.
    fn default() -> Self {
        Up {
            axis: 1,
            negative: false,
        }
    }
}

impl Up {
    /// Parses `x`, `y`, `z`, optionally prefixed by `+` or `-`.
    pub fn from_name(s: &str) -> Option<Up> {
        let (negative, a) = match s.strip_prefix('-') {
            Some(a) => (true, a),
            None => (false, s.strip_prefix('+').unwrap_or(s)),
        };
        let axis = ["x", "y", "z"].iter().position(|&n| n == a)?;
        Some(Up { axis, negative })
    }
}

/// How to render. Sizes are in output pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width, 1 to [`MAX_SIZE`].
    pub width: u32,
    /// Image height, 1 to [`MAX_SIZE`].
    pub height: u32,
    /// Camera direction.
    pub view: View,
    /// The model's up direction (image up in every view but `Top`).
    pub up: Up,
    /// Mild perspective (about 23° field of view) instead of orthographic.
    pub perspective: bool,
    /// Draw triangle edges in dark grey over the faces.
    pub wireframe: bool,
    /// Samples per pixel along each axis (1 = no antialiasing), 1 to 4.
    pub supersample: u32,
    /// Radius of overlay points.
    pub point_radius: f64,
    /// Frame this box (`min`, `max`) instead of the mesh's vertices: gives several
    /// renderings the same framing.
    pub fit: Option<([f64; 3], [f64; 3])>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 800,
            height: 800,
            view: View::Iso,
            up: Up::default(),
            perspective: false,
            wireframe: false,
            supersample: 2,
            point_radius: 1.0,
            fit: None,
        }
    }
}

/// Largest width or height accepted.
pub const MAX_SIZE: u32 = 8192;

/// Most samples an image is rendered at: width × height × supersample², and
/// the pixels of panels side by side (8192 × 8192; 11 bytes a sample).
pub const MAX_SAMPLES: u64 = 1 << 26;

/// The largest radius of an overlay dot, in pixels: a sixth of the default
/// image's width. A dot costs its area in samples, so this bounds the time
/// a point takes (at most about 13,000 pixels, times the supersampling
/// squared).
pub const MAX_POINT_RADIUS: f64 = 64.0;

/// Checks a size and supersampling against [`MAX_SIZE`], 1 to 4 and
/// [`MAX_SAMPLES`], before anything is allocated for them.
pub fn check_size(width: u32, height: u32, supersample: u32) -> Result<(), RenderError> {
    let samples = u64::from(width) * u64::from(height) * u64::from(supersample).pow(2);
    if !(1..=MAX_SIZE).contains(&width)
        || !(1..=MAX_SIZE).contains(&height)
        || !(1..=4).contains(&supersample)
        || samples > MAX_SAMPLES
    {
        return Err(RenderError::BadSize {
            width,
            height,
            supersample,
        });
    }
    Ok(())
}

/// Checks an overlay dots' radius against 0 to [`MAX_POINT_RADIUS`].
pub fn check_point_radius(radius: f64) -> Result<(), RenderError> {
    if (0.0..=MAX_POINT_RADIUS).contains(&radius) {
        Ok(())
    } else {
        Err(RenderError::BadPointRadius { radius })
    }
}

/// Colours.
const BACKGROUND: [u8; 3] = [255, 255, 255];
const FRONT: [f64; 3] = [180.0, 198.0, 228.0];
const BACK: [f64; 3] = [238.0, 170.0, 80.0];
const WIRE: [u8; 3] = [35, 38, 50];
const POINT: [u8; 3] = [215, 25, 35];
const AMBIENT: f64 = 0.3;

/// Why nothing was rendered.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum RenderError {
    /// The mesh has no triangles.
    EmptyMesh {
        /// Vertices it has.
        vertices: usize,
    },
    /// Width or height out of range, supersampling out of 1..=4, or more
    /// samples than [`MAX_SAMPLES`].
    BadSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Requested supersampling.
        supersample: u32,
    },
    /// A triangle names a vertex that does not exist.
    BadIndex {
        /// The triangle.
        face: usize,
        /// The index it holds.
        index: u32,
        /// Vertices there are.
        vertices: usize,
    },
    /// The overlay dots' radius is not 0 to [`MAX_POINT_RADIUS`] pixels.
    BadPointRadius {
        /// The radius asked for.
        radius: f64,
    },
    /// A vertex or point is NaN or infinite.
    NonFinite {
        /// `"vertex"` or `"point"`.
        what: &'static str,
        /// Its index.
        index: usize,
    },
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::EmptyMesh { vertices } => {
                write!(
                    f,
                    "the mesh has no faces ({vertices} vertices): nothing to render"
                )
            }
            RenderError::BadSize {
                width,
                height,
                supersample,
            } => write!(
                f,
                "image size {width}x{height} with {supersample}x supersampling: \
                 width and height must be 1 to {MAX_SIZE}, supersampling 1 to 4, and \
                 width x height x supersampling^2 at most {MAX_SAMPLES} samples (e.g. \
                 8192x8192, or 4096x4096 with --supersample 2)"
            ),
            RenderError::BadIndex {
                face,
                index,
                vertices,
            } => write!(
                f,
                "face {face} uses vertex {index}, but there are {vertices} vertices"
            ),
            RenderError::BadPointRadius { radius } => write!(
                f,
                "point radius {radius}: must be 0 to {MAX_POINT_RADIUS} pixels"
            ),
            RenderError::NonFinite { what, index } => {
                write!(f, "{what} {index} has a coordinate that is not finite")
            }
        }
    }
}

impl std::error::Error for RenderError {}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        a.map(|v| v / n)
    } else {
        a
    }
}

fn axis(i: usize, s: f64) -> [f64; 3] {
    let mut a = [0.0; 3];
    a[i] = s;
    a
}

/// Camera: an orthonormal view frame around `centre` and the fitted screen mapping.
struct Camera {
    centre: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    eye: [f64; 3],
    /// Camera distance from the centre for perspective, else `None`.
    distance: Option<f64>,
    /// Screen mapping: pixel = offset + scale * (projected x, -projected y).
    scale: f64,
    offset: [f64; 2],
}

impl Camera {
    /// A camera around the box `lo`..`hi`, scaled so the projection of `fit` fills
    /// 88 % of the `w` x `h` image and centred on it.
    fn new(
        (lo, hi): ([f64; 3], [f64; 3]),
        fit: impl Iterator<Item = [f64; 3]>,
        opts: &RenderOptions,
        w: f64,
        h: f64,
    ) -> Camera {
        let s = if opts.up.negative { -1.0 } else { 1.0 };
        let u = axis(opts.up.axis, s);
        // Right-hand side of the model seen from the front: +x, or +y when x is up.
        let r = if opts.up.axis == 0 {
            axis(1, 1.0)
        } else {
            axis(0, 1.0)
        };
        let f = cross(r, u); // towards a viewer in front
        let (eye, img_up) = match opts.view {
            View::Front => (f, u),
            View::Side => (r, u),
            View::Top => (u, f.map(|v| -v)),
            View::Iso => {
                let (az, el) = (35f64.to_radians(), 25f64.to_radians());
                let e = [0, 1, 2]
                    .map(|i| el.cos() * (az.cos() * f[i] + az.sin() * r[i]) + el.sin() * u[i]);
                (normalize(e), u)
            }
        };
        let right = normalize(cross(img_up, eye));
        let up = cross(eye, right);
        let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
        let radius = 0.5 * dot(sub(hi, lo), sub(hi, lo)).sqrt();
        let mut cam = Camera {
            centre,
            right,
            up,
            eye,
            // A field of view of about 23° over the bounding sphere.
            distance: opts
                .perspective
                .then_some(5.0 * radius.max(f64::MIN_POSITIVE)),
            scale: 1.0,
            offset: [0.0; 2],
        };
        let (mut min, mut max) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in fit {
            let q = cam.project(p);
            for k in 0..2 {
                min[k] = min[k].min(q[k]);
                max[k] = max[k].max(q[k]);
            }
        }
        let ext = [max[0] - min[0], max[1] - min[1]];
        let fit = 0.88;
        let sx = if ext[0] > 0.0 {
            fit * w / ext[0]
        } else {
            f64::INFINITY
        };
        let sy = if ext[1] > 0.0 {
            fit * h / ext[1]
        } else {
            f64::INFINITY
        };
        cam.scale = if sx.min(sy).is_finite() {
            sx.min(sy)
        } else {
            1.0
        };
        cam.offset = [
            0.5 * w - cam.scale * 0.5 * (min[0] + max[0]),
            0.5 * h + cam.scale * 0.5 * (min[1] + max[1]),
        ];
        cam
    }

    /// View coordinates: x right, y up, z towards the camera.
    fn view(&self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(p, self.centre);
        [dot(d, self.right), dot(d, self.up), dot(d, self.eye)]
    }

    /// Projected x, y (before the screen mapping) and a depth that grows towards the
    /// camera and is linear in screen space.
    fn project(&self, p: [f64; 3]) -> [f64; 3] {
        let v = self.view(p);
        match self.distance {
            None => v,
            Some(d) => {
                let inv = 1.0 / (d - v[2]).max(1e-9 * d);
                [v[0] * d * inv, v[1] * d * inv, inv]
            }
        }
    }

    /// Pixel x, y (supersampled) and depth.
    fn screen(&self, p: [f64; 3]) -> [f64; 3] {
        let q = self.project(p);
        [
            self.offset[0] + self.scale * q[0],
            self.offset[1] - self.scale * q[1],
            q[2],
        ]
    }

    /// Whether the face with view-space corners `v` faces the camera (counter-clockwise
    /// seen from it), and its unit normal oriented towards the camera.
    fn facing(&self, v: &[[f64; 3]; 3]) -> (bool, [f64; 3]) {
        let n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
        let to_cam = match self.distance {
            None => [0.0, 0.0, 1.0],
            Some(d) => sub([0.0, 0.0, d], v[0]),
        };
        let front = dot(n, to_cam) >= 0.0;
        let n = normalize(n);
        (front, if front { n } else { n.map(|x| -x) })
    }
}

/// Sample buffers at supersampled resolution.
struct Target {
    w: usize,
    h: usize,
    colour: Vec<[u8; 3]>,
    depth: Vec<f64>,
}

impl Target {
    fn triangle(&mut self, s: &[[f64; 3]; 3], c: [u8; 3]) {
        let area = edge(s[0], s[1], s[2]);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        let x0 = s.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
        let x1 = s.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max);
        let y0 = s.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let y1 = s.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        let (xa, xb) = (clamp_px(x0 - 0.5, self.w), clamp_px(x1 - 0.5, self.w));
        let (ya, yb) = (clamp_px(y0 - 0.5, self.h), clamp_px(y1 - 0.5, self.h));
        if x1 < 0.0 || y1 < 0.0 {
            return;
        }
        let inv = 1.0 / area;
        for y in ya..=yb {
            let py = y as f64 + 0.5;
            for x in xa..=xb {
                let p = [x as f64 + 0.5, py, 0.0];
                let w0 = edge(s[1], s[2], p) * inv;
                let w1 = edge(s[2], s[0], p) * inv;
                let w2 = edge(s[0], s[1], p) * inv;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let d = w0 * s[0][2] + w1 * s[1][2] + w2 * s[2][2];
                let i = y * self.w + x;
                if d > self.depth[i] {
                    self.depth[i] = d;
                    self.colour[i] = c;
                }
            }
        }
    }

    /// A line `thick` samples wide, drawn where it is at most `bias` behind the surface.
    fn line(&mut self, a: [f64; 3], b: [f64; 3], thick: usize, bias: f64, c: [u8; 3]) {
        let steps = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil().max(1.0);
        if !steps.is_finite() || steps > 1e6 {
            return;
        }
        let lo = (thick as isize - 1) / 2;
        for k in 0..=steps as usize {
            let t = k as f64 / steps;
            let p = [0, 1, 2].map(|i| a[i] + t * (b[i] - a[i]));
            let (cx, cy) = ((p[0] - 0.5).round() as isize, (p[1] - 0.5).round() as isize);
            for dy in 0..thick as isize {
                for dx in 0..thick as isize {
                    self.plot(cx + dx - lo, cy + dy - lo, p[2] + bias, c);
                }
            }
        }
    }

    /// A disc of radius `r` samples around `p`, drawn where at most `bias` behind.
    fn dot(&mut self, p: [f64; 3], r: f64, bias: f64, c: [u8; 3]) {
        let (cx, cy) = (p[0] - 0.5, p[1] - 0.5);
        if !(cx.is_finite() && cy.is_finite() && r.is_finite()) {
            return;
        }
        // Only the rows and columns of the target the dot's box meets: a dot
        // far off screen costs nothing.
        let (w, h) = (self.w as f64, self.h as f64);
        let y0 = (cy - r).ceil().max(0.0);
        let y1 = (cy + r).floor().min(h - 1.0);
        let x0 = (cx - r).ceil().max(0.0);
        let x1 = (cx + r).floor().min(w - 1.0);
        if y0 > y1 || x0 > x1 {
            return;
        }
        for y in y0 as isize..=y1 as isize {
            for x in x0 as isize..=x1 as isize {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                if dx * dx + dy * dy <= r * r {
                    self.plot(x, y, p[2] + bias, c);
                }
            }
        }
    }

    /// Colours sample (x, y) if `d` is not behind the surface there (no depth write).
    fn plot(&mut self, x: isize, y: isize, d: f64, c: [u8; 3]) {
        if x < 0 || y < 0 || x as usize >= self.w || y as usize >= self.h {
            return;
        }
        let i = y as usize * self.w + x as usize;
        if d >= self.depth[i] {
            self.colour[i] = c;
        }
    }

    /// Box-filters `s` x `s` samples into one pixel.
    fn resolve(&self, s: usize) -> Image {
        let (w, h) = (self.w / s, self.h / s);
        let mut img = Image::filled(w as u32, h as u32, BACKGROUND);
        let n = (s * s) as u32;
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0u32; 3];
                for sy in 0..s {
                    for sx in 0..s {
                        let c = self.colour[(y * s + sy) * self.w + x * s + sx];
                        for k in 0..3 {
                            acc[k] += u32::from(c[k]);
                        }
                    }
                }
                img.put(x as u32, y as u32, acc.map(|a| ((a + n / 2) / n) as u8));
            }
        }
        img
    }
}

fn clamp_px(v: f64, n: usize) -> usize {
    if v <= 0.0 {
        0
    } else {
        (v.ceil() as usize).min(n - 1)
    }
}

/// Twice the signed area of (a, b, p) in screen space.
fn edge(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

fn check_finite(what: &'static str, pts: &[[f64; 3]]) -> Result<(), RenderError> {
    match pts.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        Some(index) => Err(RenderError::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// Renders the mesh (and `points`, when given, as dots) with `opts`.
///
/// Errors, never panics: no triangles, an index out of range, a non-finite coordinate,
/// or a size out of range. Cost: O(V + F + P + covered samples).
pub fn render_mesh(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    points: Option<&[[f64; 3]]>,
    opts: &RenderOptions,
) -> Result<Image, RenderError> {
    let ss = opts.supersample;
    check_size(opts.width, opts.height, ss)?;
    check_point_radius(opts.point_radius)?;
    if triangles.is_empty() {
        return Err(RenderError::EmptyMesh {
            vertices: vertices.len(),
        });
    }
    for (face, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(RenderError::BadIndex {
                face,
                index,
                vertices: vertices.len(),
            });
        }
    }
    check_finite("vertex", vertices)?;
    let points = points.unwrap_or(&[]);
    check_finite("point", points)?;

    // The referenced vertices: unused ones do not move the camera.
    let used = || triangles.iter().flatten().map(|&i| vertices[i as usize]);
    let bounds = opts.fit.unwrap_or_else(|| {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in used() {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    });
    let s = ss as usize;
    let (w, h) = (opts.width as usize * s, opts.height as usize * s);
    let cam = match opts.fit {
        // The same framing for any mesh in this box: fit its corners.
        Some((lo, hi)) => {
            let corners =
                (0..8).map(|c| [0, 1, 2].map(|i| if c >> i & 1 == 0 { lo[i] } else { hi[i] }));
            Camera::new(bounds, corners, opts, w as f64, h as f64)
        }
        None => Camera::new(bounds, used(), opts, w as f64, h as f64),
    };
    let mut target = Target {
        w,
        h,
        colour: vec![BACKGROUND; w * h],
        depth: vec![f64::NEG_INFINITY; w * h],
    };
    let screen: Vec<[f64; 3]> = vertices.iter().map(|&p| cam.screen(p)).collect();
    let (dmin, dmax) = screen
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p[2]), b.max(p[2]))
        });
    let range = (dmax - dmin).max(f64::MIN_POSITIVE);
    let light = normalize([-0.4, 0.6, 1.0]);

    for t in triangles {
        let v = t.map(|i| cam.view(vertices[i as usize]));
        let (front, n) = cam.facing(&v);
        let base = if front { FRONT } else { BACK };
        let k = AMBIENT + (1.0 - AMBIENT) * dot(n, light).max(0.0);
        let c = base.map(|b| (b * k).round().clamp(0.0, 255.0) as u8);
        target.triangle(&t.map(|i| screen[i as usize]), c);
    }
    if opts.wireframe {
        for t in triangles {
            for e in 0..3 {
                let (a, b) = (screen[t[e] as usize], screen[t[(e + 1) % 3] as usize]);
                target.line(a, b, s, 0.005 * range, WIRE);
            }
        }
    }
    for &p in points {
        target.dot(
            cam.screen(p),
            opts.point_radius * s as f64,
            0.01 * range,
            POINT,
        );
    }
    Ok(target.resolve(s))
}

/// Writes `img` as an 8-bit RGB PNG, atomically (see [`write_atomic`]).
pub fn save_png(path: &Path, img: &Image) -> Result<(), WriteError> {
    write_atomic(path, |w| write_png(w, img))
}

/// Encodes `img` as an 8-bit RGB PNG into `w`.
pub fn write_png(w: &mut dyn io::Write, img: &Image) -> io::Result<()> {
    let mut enc = png::Encoder::new(w, img.width, img.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(io::Error::other)?;
    writer
        .write_image_data(&img.pixels)
        .map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}

/// Height of a label band in [`hstack`]: 7-row glyphs at scale 2 plus padding.
const LABEL_SCALE: u32 = 2;
const LABEL_BAND: u32 = 7 * LABEL_SCALE + 10;

/// Puts `images` side by side, top-aligned on white, with `labels` (one per image,
/// upper-cased, centred above each) when given. An empty list gives a 1x1 white image.
pub fn hstack(images: &[Image], labels: Option<&[&str]>) -> Image {
    let band = if labels.is_some() { LABEL_BAND } else { 0 };
    let width = images.iter().map(|i| i.width).sum::<u32>().max(1);
    let height = images.iter().map(|i| i.height).max().unwrap_or(0) + band;
    let mut out = Image::filled(width, height.max(1), BACKGROUND);
    let mut x0 = 0;
    for (k, img) in images.iter().enumerate() {
        for y in 0..img.height {
            let src = 3 * (y as usize * img.width as usize);
            let dst = 3 * ((y + band) as usize * width as usize + x0 as usize);
            let n = 3 * img.width as usize;
            out.pixels[dst..dst + n].copy_from_slice(&img.pixels[src..src + n]);
        }
        if let Some(text) = labels.and_then(|l| l.get(k)) {
            let tw = text.chars().count() as u32 * 6 * LABEL_SCALE;
            let x = x0 + img.width.saturating_sub(tw) / 2;
            draw_text(&mut out, x, 5, text, LABEL_SCALE, [0, 0, 0]);
        }
        x0 += img.width;
    }
    out
}

/// Draws `text` with the built-in 5x7 font (6 pixels per character at scale 1),
/// top-left at (x, y), clipped to the image.
pub fn draw_text(img: &mut Image, x: u32, y: u32, text: &str, scale: u32, colour: [u8; 3]) {
    for (n, ch) in text.chars().enumerate() {
        let rows = glyph(ch);
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits >> (4 - col) & 1 == 0 {
                    continue;
                }
                for sy in 0..scale {
                    for sx in 0..scale {
                        let px = x + (n as u32 * 6 + col) * scale + sx;
                        let py = y + r as u32 * scale + sy;
                        if px < img.width && py < img.height {
                            img.put(px, py, colour);
                        }
                    }
                }
            }
        }
    }
}

/// Rows (top first, 5 bits, leftmost column in bit 4) of a character; lower case is
/// drawn as upper case, anything unknown as `?`.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        ' ' => [0; 7],
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '.' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        '-' => [0, 0, 0, 0x1F, 0, 0, 0],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '#' => [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0, 0x04],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube, 12 outward faces.
    fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64])
            .collect();
        let t = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        (v, t)
    }

    #[test]
    fn cube_fills_the_centre_on_a_white_background_at_the_requested_size() {
        let (v, t) = cube();
        for view in [View::Iso, View::Front, View::Side, View::Top] {
            for perspective in [false, true] {
                let opts = RenderOptions {
                    width: 120,
                    height: 90,
                    view,
                    perspective,
                    wireframe: true,
                    ..RenderOptions::default()
                };
                let img = render_mesh(&v, &t, Some(&[[0.5, 0.5, 1.0]]), &opts).unwrap();
                assert_eq!((img.width, img.height), (120, 90));
                assert_eq!(img.pixels.len(), 120 * 90 * 3);
                for (x, y) in [(0, 0), (119, 0), (0, 89), (119, 89)] {
                    assert_eq!(img.pixel(x, y), BACKGROUND, "{view:?} corner {x},{y}");
                }
                assert_ne!(img.pixel(60, 45), BACKGROUND, "{view:?}");
                // A closed, outward cube shows no back faces: nothing amber (red > green
                // > blue; the red dot blends towards white or blue, never like that).
                let amber = img
                    .pixels
                    .chunks(3)
                    .filter(|p| p[0] > p[1] && u16::from(p[1]) > u16::from(p[2]) + 30)
                    .count();
                assert_eq!(amber, 0, "{view:?} perspective {perspective}");
            }
        }
    }

    #[test]
    fn rendering_and_png_bytes_are_deterministic() {
        let (v, t) = cube();
        let opts = RenderOptions {
            width: 64,
            height: 48,
            wireframe: true,
            ..RenderOptions::default()
        };
        let pts = [[0.5, 0.5, 1.0], [1.0, 1.0, 1.0]];
        let a = render_mesh(&v, &t, Some(&pts), &opts).unwrap();
        let b = render_mesh(&v, &t, Some(&pts), &opts).unwrap();
        assert_eq!(a, b);
        let dir = std::env::temp_dir().join(format!("vsaqem-render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (pa, pb) = (dir.join("a.png"), dir.join("b.png"));
        save_png(&pa, &a).unwrap();
        save_png(&pb, &b).unwrap();
        let (ba, bb) = (std::fs::read(&pa).unwrap(), std::fs::read(&pb).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(ba, bb);
        assert_eq!(&ba[..8], b"\x89PNG\r\n\x1a\n");
    }

    #[test]
    fn empty_mesh_is_an_error() {
        let (v, _) = cube();
        let err = render_mesh(&v, &[], None, &RenderOptions::default()).unwrap_err();
        assert_eq!(err, RenderError::EmptyMesh { vertices: 8 });
        assert!(err.to_string().contains("no faces"));
        assert!(render_mesh(&[], &[], None, &RenderOptions::default()).is_err());
    }

    #[test]
    fn open_mesh_shows_its_inside_in_the_back_colour() {
        // The cube without its front (+z) faces, seen from the front.
        let (v, mut t) = cube();
        t.drain(2..4);
        let opts = RenderOptions {
            width: 60,
            height: 60,
            view: View::Front,
            ..RenderOptions::default()
        };
        let c = render_mesh(&v, &t, None, &opts).unwrap().pixel(30, 30);
        assert!(c[0] > c[2], "{c:?}");
    }

    fn quad() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ];
        (v, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn front_view_of_a_square_facing_the_camera_is_front_coloured() {
        let (v, t) = quad();
        let opts = RenderOptions {
            width: 50,
            height: 50,
            view: View::Front,
            ..RenderOptions::default()
        };
        let img = render_mesh(&v, &t, None, &opts).unwrap();
        let c = img.pixel(25, 25);
        // Blue-dominant, i.e. the front colour, not the amber back.
        assert!(c[2] > c[0], "{c:?}");
        let flipped: Vec<[u32; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
        let back = render_mesh(&v, &flipped, None, &opts)
            .unwrap()
            .pixel(25, 25);
        assert!(back[0] > back[2], "{back:?}");
    }

    #[test]
    fn up_axis_puts_the_top_of_the_model_at_the_top_of_the_image() {
        // A triangle pointing up along +z, seen from the front with z up.
        let v = vec![[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]];
        let opts = RenderOptions {
            width: 40,
            height: 40,
            view: View::Front,
            up: Up::from_name("z").unwrap(),
            supersample: 1,
            ..RenderOptions::default()
        };
        let img = render_mesh(&v, &[[0, 1, 2]], None, &opts).unwrap();
        let row_filled = |y| (0..40).filter(|&x| img.pixel(x, y) != BACKGROUND).count();
        // Narrow apex near the top, wide base near the bottom.
        assert!(
            row_filled(8) < row_filled(30),
            "{} {}",
            row_filled(8),
            row_filled(30)
        );
    }

    #[test]
    fn up_parses_signed_axes() {
        assert_eq!(
            Up::from_name("-z"),
            Some(Up {
                axis: 2,
                negative: true
            })
        );
        assert_eq!(
            Up::from_name("+x"),
            Some(Up {
                axis: 0,
                negative: false
            })
        );
        assert_eq!(Up::from_name("w"), None);
    }

    #[test]
    fn hstack_sums_widths_and_adds_a_label_band() {
        let a = Image::filled(10, 20, [0, 0, 0]);
        let b = Image::filled(30, 5, [0, 0, 0]);
        let s = hstack(&[a.clone(), b.clone()], None);
        assert_eq!((s.width, s.height), (40, 20));
        assert_eq!(s.pixel(35, 10), BACKGROUND);
        assert_eq!(s.pixel(5, 10), [0, 0, 0]);
        let l = hstack(&[a, b], Some(&["a", "b"]));
        assert_eq!((l.width, l.height), (40, 20 + LABEL_BAND));
        assert!(l.pixels.chunks(3).take(40 * 20).any(|p| p == [0, 0, 0]));
    }

    #[test]
    fn the_samples_of_an_image_are_bounded_before_it_is_allocated() {
        assert!(check_size(8192, 8192, 1).is_ok());
        assert!(check_size(4096, 4096, 2).is_ok());
        assert!(check_size(2048, 2048, 4).is_ok());
        for (w, h, ss) in [(8192, 8192, 4), (4096, 4096, 3), (8193, 1, 1), (1, 1, 5)] {
            let e = check_size(w, h, ss).unwrap_err().to_string();
            assert!(e.contains(&format!("{w}x{h} with {ss}x")) && e.contains("67108864"));
        }
    }

    #[test]
    fn bad_index_and_size_are_errors() {
        let (v, _) = quad();
        let o = RenderOptions::default();
        assert!(matches!(
            render_mesh(&v, &[[0, 1, 9]], None, &o),
            Err(RenderError::BadIndex {
                face: 0,
                index: 9,
                ..
            })
        ));
        let big = RenderOptions {
            width: 0,
            ..RenderOptions::default()
        };
        assert!(matches!(
            render_mesh(&v, &[[0, 1, 2]], None, &big),
            Err(RenderError::BadSize { .. })
        ));
    }

    #[test]
    fn overlay_dots_are_bounded_and_clipped_to_the_image() {
        let (v, t) = cube();
        let plain = render_mesh(&v, &t, None, &RenderOptions::default()).unwrap();
        // A radius past the limit, negative or NaN is refused, not drawn.
        for radius in [MAX_POINT_RADIUS + 1.0, 100_000.0, -1.0, f64::NAN] {
            let o = RenderOptions {
                point_radius: radius,
                ..RenderOptions::default()
            };
            let e = render_mesh(&v, &t, Some(&[[0.0; 3]]), &o).unwrap_err();
            assert!(matches!(e, RenderError::BadPointRadius { .. }), "{e}");
            assert!(e.to_string().contains("must be 0 to 64 pixels"), "{e}");
        }
        let wide = RenderOptions {
            point_radius: MAX_POINT_RADIUS,
            ..RenderOptions::default()
        };
        // A dot at a corner of the cube covers about a quarter disc there
        // (its depth bias puts it in front of the faces it meets).
        let corner = render_mesh(&v, &t, Some(&[[1.0, 1.0, 1.0]]), &wide).unwrap();
        let red = corner.pixels.chunks(3).filter(|p| p == &POINT).count();
        let disc = std::f64::consts::PI * MAX_POINT_RADIUS * MAX_POINT_RADIUS;
        assert!(
            red as f64 > 0.2 * disc && (red as f64) < 1.05 * disc,
            "{red}"
        );
        // Points far outside the view draw nothing (and cost nothing).
        let far = [[1e6, 1e6, 0.0], [-1e6, 0.0, 0.0], [0.0, -1e6, 1e6]];
        let off = render_mesh(&v, &t, Some(&far), &wide).unwrap();
        assert!(off.pixels == plain.pixels);
    }
}

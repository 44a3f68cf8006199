//! Pixel bookkeeping for placing the legend and marker labels where they
//! hide the least: rectangles and the cells that curves pass through.

/// Pixel rectangle `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rect {
    pub(crate) x0: i32,
    pub(crate) y0: i32,
    pub(crate) x1: i32,
    pub(crate) y1: i32,
}

impl Rect {
    pub(crate) fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
    /// Squared distance from a point to the rectangle (0 inside).
    pub(crate) fn distance2(&self, (x, y): (i32, i32)) -> i64 {
        let dx = i64::from((self.x0 - x).max(x - self.x1).max(0));
        let dy = i64::from((self.y0 - y).max(y - self.y1).max(0));
        dx * dx + dy * dy
    }
    pub(crate) fn within(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

/// Which cells (of `CELL` pixels) of the plotting area curves pass through,
/// so the legend and marker labels can be put where they hide least data.
pub(crate) struct Occupancy {
    w: usize,
    h: usize,
    cells: Vec<bool>,
}

const CELL: i32 = 4;

impl Occupancy {
    pub(crate) fn new(w: i32, h: i32) -> Self {
        let (w, h) = (
            (w / CELL + 1).max(1) as usize,
            (h / CELL + 1).max(1) as usize,
        );
        Self {
            w,
            h,
            cells: vec![false; w * h],
        }
    }
    fn mark(&mut self, (x, y): (f64, f64)) {
        let (cx, cy) = ((x / f64::from(CELL)).floor(), (y / f64::from(CELL)).floor());
        if cx >= 0.0 && cy >= 0.0 && (cx as usize) < self.w && (cy as usize) < self.h {
            self.cells[cy as usize * self.w + cx as usize] = true;
        }
    }
    /// Marks the pixel polyline densely enough to leave no gaps.
    pub(crate) fn mark_path(&mut self, pts: &[(i32, i32)]) {
        if let [p] = pts {
            self.mark((f64::from(p.0), f64::from(p.1)));
        }
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = f64::from((b.0 - a.0).abs().max((b.1 - a.1).abs()));
            let n = (len / f64::from(CELL) * 2.0).ceil().max(1.0) as i32;
            for i in 0..=n {
                let t = f64::from(i) / f64::from(n);
                self.mark((
                    f64::from(a.0) + t * f64::from(b.0 - a.0),
                    f64::from(a.1) + t * f64::from(b.1 - a.1),
                ));
            }
        }
    }
    pub(crate) fn count(&self, r: &Rect) -> usize {
        let cx = |x: i32| (x / CELL).clamp(0, self.w as i32 - 1) as usize;
        let cy = |y: i32| (y / CELL).clamp(0, self.h as i32 - 1) as usize;
        let mut n = 0;
        for y in cy(r.y0)..=cy(r.y1 - 1) {
            n += self.cells[y * self.w + cx(r.x0)..=y * self.w + cx(r.x1 - 1)]
                .iter()
                .filter(|&&c| c)
                .count();
        }
        n
    }
}

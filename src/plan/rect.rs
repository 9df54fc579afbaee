//! Pixel rectangles of the image: scissors, and the regions of an image a frame
//! clears, copies and reads (`plan::reach`). Pure; the executor resolves a
//! plan's `Scissor`s into these (`vk/scissor.rs`).

/// A pixel rectangle `[x0, x1) × [y0, y1)`, y downward.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rect {
    pub(crate) x0: u32,
    pub(crate) y0: u32,
    pub(crate) x1: u32,
    pub(crate) y1: u32,
}

impl Rect {
    /// The whole `width` × `height` image.
    pub fn full(width: u32, height: u32) -> Rect {
        Rect {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    pub(crate) const EMPTY: Rect = Rect {
        x0: 0,
        y0: 0,
        x1: 0,
        y1: 0,
    };

    pub(crate) fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    pub(crate) fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// The number of pixels.
    pub fn area(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// Whether it holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.area() == 0
    }

    /// Whether `o` lies inside `self`.
    pub fn contains(&self, o: &Rect) -> bool {
        self.x0 <= o.x0 && self.y0 <= o.y0 && o.x1 <= self.x1 && o.y1 <= self.y1
    }

    /// `self` grown by `mx` pixels left and right and `my` up and down, within a
    /// `width × height` image; an empty rectangle stays empty.
    pub fn grown(&self, mx: u32, my: u32, width: u32, height: u32) -> Rect {
        if self.is_empty() {
            return *self;
        }
        Rect {
            x0: self.x0.saturating_sub(mx),
            y0: self.y0.saturating_sub(my),
            x1: (self.x1 + mx).min(width),
            y1: (self.y1 + my).min(height),
        }
    }

    /// The pixels in both; an empty rectangle when they do not meet.
    pub fn intersect(&self, o: &Rect) -> Rect {
        let r = Rect {
            x0: self.x0.max(o.x0),
            y0: self.y0.max(o.y0),
            x1: self.x1.min(o.x1),
            y1: self.y1.min(o.y1),
        };
        if r.is_empty() {
            Rect::EMPTY
        } else {
            r
        }
    }

    pub(crate) fn union(&self, o: &Rect) -> Rect {
        if self.is_empty() {
            return *o;
        }
        if o.is_empty() {
            return *self;
        }
        Rect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }
}

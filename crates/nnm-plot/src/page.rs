//! One image (a single chart or a grid of them), written as PNG and SVG.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::panel::Panel;
use crate::style::{FONT, GRID_TITLE, SIZE};
use crate::{PlotError, register_fonts};

/// One image: an optional overall title and panels filled row by row.
pub(crate) struct Page<'a> {
    pub(crate) title: Option<&'a str>,
    pub(crate) columns: usize,
    pub(crate) rows: usize,
    pub(crate) size: (u32, u32),
    /// Text and spacing scale of the panels.
    pub(crate) scale: f64,
    pub(crate) panels: Vec<Panel<'a>>,
}

impl<'a> Page<'a> {
    pub(crate) fn single(panel: Panel<'a>) -> Self {
        Page {
            title: None,
            columns: 1,
            rows: 1,
            size: SIZE,
            scale: 1.0,
            panels: vec![panel],
        }
    }

    pub(crate) fn write(&self, stem: &Path) -> Result<(), PlotError> {
        register_fonts()?;
        let png = with_suffix(stem, ".png");
        let root = BitMapBackend::new(&png, self.size).into_drawing_area();
        self.draw(&root, true)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: png.clone(),
                message,
            })?;
        let svg = with_suffix(stem, ".svg");
        let root = SVGBackend::new(&svg, self.size).into_drawing_area();
        self.draw(&root, false)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: svg.clone(),
                message,
            })
    }

    /// `bitmap`: see [`Panel::draw`].
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        bitmap: bool,
    ) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        let area = match self.title {
            Some(t) => {
                let (top, rest) = root.split_vertically(GRID_TITLE);
                let style = TextStyle::from((FONT, 32).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Center));
                let w = top.dim_in_pixel().0 as i32;
                top.draw_text(t, &style, (w / 2, GRID_TITLE as i32 / 2 + 4))
                    .map_err(err)?;
                rest
            }
            None => root.clone(),
        };
        let cells = area.split_evenly((self.rows, self.columns));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            panel.draw(cell, self.scale, bitmap)?;
        }
        Ok(())
    }
}

/// `stem` + suffix. Not `Path::with_extension`, which would turn a stem like
/// `fep_amp0.5` into `fep_amp0.png`.
fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

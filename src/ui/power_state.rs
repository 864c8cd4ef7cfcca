//! The CiA 402 power state machine drawn from 6041h, the current state highlighted, so a
//! technician sees at a glance why a command is refused (a fault active, a quick stop).

use eframe::egui::{self, Color32, FontId, Pos2, Rect, Sense, Stroke, Ui, Vec2, WidgetInfo};

use super::widgets::{AMBER, GREEN, RED};
use crate::cia::PowerState;

/// Where each state sits: (column, row) on a 2 × 5 grid.
fn place(state: PowerState) -> (usize, usize) {
    match state {
        PowerState::NotReadyToSwitchOn => (0, 0),
        PowerState::SwitchOnDisabled => (0, 1),
        PowerState::ReadyToSwitchOn => (0, 2),
        PowerState::SwitchedOn => (0, 3),
        PowerState::OperationEnabled => (0, 4),
        PowerState::FaultReactionActive => (1, 0),
        PowerState::Fault => (1, 1),
        PowerState::QuickStopActive => (1, 4),
    }
}

/// The transitions drawn (CiA 402 figure, the ones a technician meets).
const ARROWS: [(PowerState, PowerState); 8] = [
    (PowerState::NotReadyToSwitchOn, PowerState::SwitchOnDisabled),
    (PowerState::SwitchOnDisabled, PowerState::ReadyToSwitchOn),
    (PowerState::ReadyToSwitchOn, PowerState::SwitchedOn),
    (PowerState::SwitchedOn, PowerState::OperationEnabled),
    (PowerState::OperationEnabled, PowerState::QuickStopActive),
    (PowerState::FaultReactionActive, PowerState::Fault),
    (PowerState::Fault, PowerState::SwitchOnDisabled),
    (PowerState::QuickStopActive, PowerState::OperationEnabled),
];

/// What a command meets in this state.
fn consequence(state: PowerState) -> &'static str {
    match state {
        PowerState::Fault | PowerState::FaultReactionActive => {
            "travel commands are refused until the cause is gone and Clear Error is sent"
        }
        PowerState::QuickStopActive => "a travel command resumes operation",
        PowerState::OperationEnabled => "commands are carried out",
        PowerState::NotReadyToSwitchOn => "wait: the drive is starting",
        _ => "a travel command switches the power stage on and starts",
    }
}

fn color(state: PowerState) -> Color32 {
    match state {
        PowerState::OperationEnabled => GREEN,
        PowerState::Fault | PowerState::FaultReactionActive => RED,
        PowerState::QuickStopActive => AMBER,
        _ => Color32::from_rgb(120, 160, 220),
    }
}

/// Where the boxes go in the area allocated: two columns of five rows.
struct Layout {
    area: Rect,
    box_h: f32,
    gap: f32,
    col_w: [f32; 2],
    col_x: [f32; 2],
}

impl Layout {
    fn rect_of(&self, state: PowerState) -> Rect {
        let (c, r) = place(state);
        Rect::from_min_size(
            Pos2::new(
                self.col_x[c],
                self.area.top() + r as f32 * (self.box_h + self.gap),
            ),
            Vec2::new(self.col_w[c], self.box_h),
        )
    }
}

pub fn power_state_ui(ui: &mut Ui, current: Option<PowerState>) {
    let width = ui.available_width().clamp(180.0, 320.0);
    let box_h = 18.0;
    let gap = 7.0;
    let height = 5.0 * box_h + 4.0 * gap;
    let (area, _) = ui.allocate_exact_size(Vec2::new(width, height), Sense::hover());
    let layout = Layout {
        area,
        box_h,
        gap,
        col_w: [width * 0.56, width * 0.40],
        col_x: [area.left(), area.left() + width * 0.60],
    };
    let painter = ui.painter_at(area.expand(2.0));
    let line = ui.visuals().weak_text_color();
    for (from, to) in ARROWS {
        let (start, end) = arrow_ends(&layout, from, to);
        painter.arrow(start, end - start, Stroke::new(1.0, line));
    }
    for state in PowerState::ALL {
        state_box_ui(
            ui,
            &painter,
            layout.rect_of(state),
            state,
            current == Some(state),
        );
    }
}

/// Where the arrow of a transition starts and ends: from box edge to box edge, the two
/// ways between the columns kept apart.
fn arrow_ends(layout: &Layout, from: PowerState, to: PowerState) -> (Pos2, Pos2) {
    let (a, b) = (layout.rect_of(from), layout.rect_of(to));
    if place(from).0 == place(to).0 {
        if b.top() > a.bottom() {
            (a.center_bottom(), b.center_top())
        } else {
            (a.center_top(), b.center_bottom())
        }
    } else if b.left() > a.right() {
        (
            a.right_center() + Vec2::new(0.0, -3.0),
            b.left_center() + Vec2::new(0.0, -3.0),
        )
    } else {
        (
            a.left_center() + Vec2::new(0.0, 3.0),
            b.right_center() + Vec2::new(0.0, 3.0),
        )
    }
}

/// One state's box, filled when it is the drive's; hover tells its meaning.
fn state_box_ui(ui: &mut Ui, painter: &egui::Painter, rect: Rect, state: PowerState, on: bool) {
    let fill = if on {
        color(state)
    } else {
        ui.visuals().extreme_bg_color
    };
    painter.rect_filled(rect, 3.0, fill);
    painter.rect_stroke(
        rect,
        3.0,
        Stroke::new(1.0, color(state).gamma_multiply(if on { 1.0 } else { 0.5 })),
        egui::StrokeKind::Inside,
    );
    painter.text(
        rect.center(),
        egui::Align2::CENTER_CENTER,
        state.name(),
        FontId::proportional(10.5),
        if on {
            Color32::BLACK
        } else {
            ui.visuals().weak_text_color()
        },
    );
    // Screen readers (and tests) see each state, the current one selected.
    let response = ui
        .interact(
            rect,
            ui.scope_id().with(("power_state", state.name())),
            Sense::hover(),
        )
        .on_hover_text(format!("{}\n{}", state.meaning(), consequence(state)));
    response.widget_info(|| {
        WidgetInfo::selected(egui::accesskit::Role::RadioButton, true, on, state.name())
    });
}

//! The machine at a glance, as data: which column the overview of every drive is sorted by,
//! and the order that gives.
//!
//! A model: no egui here.

use std::cmp::Ordering;

use super::drive_row::DriveRow;

/// A column of the overview.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Column {
    /// The list's own order (as added).
    #[default]
    Added,
    Name,
    State,
    Position,
    Velocity,
    Fault,
    Link,
}

impl Column {
    pub const ALL: [Column; 6] = [
        Column::Name,
        Column::State,
        Column::Position,
        Column::Velocity,
        Column::Fault,
        Column::Link,
    ];

    pub fn title(self) -> &'static str {
        match self {
            Column::Added => "#",
            Column::Name => "Drive",
            Column::State => "State",
            Column::Position => "Position",
            Column::Velocity => "Velocity",
            Column::Fault => "Fault",
            Column::Link => "Link",
        }
    }
}

/// How the overview is sorted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MachineSort {
    pub by: Column,
    pub descending: bool,
}

impl MachineSort {
    /// A click on `column`'s title: sort by it, or turn the order round if it already is.
    pub fn click(&mut self, column: Column) {
        if self.by == column {
            self.descending = !self.descending;
        } else {
            *self = MachineSort {
                by: column,
                descending: false,
            };
        }
    }

    /// The rows' indices in this order (rows with nothing to sort by last, either way).
    pub fn order(&self, rows: &[DriveRow]) -> Vec<usize> {
        let mut order: Vec<usize> = (0..rows.len()).collect();
        order.sort_by(|&a, &b| {
            let (ra, rb) = (&rows[a], &rows[b]);
            let by = match self.by {
                Column::Added => a.cmp(&b),
                Column::Name => ra.name.to_lowercase().cmp(&rb.name.to_lowercase()),
                Column::State => ra.state.cmp(&rb.state),
                Column::Position => {
                    return numbers(ra.position_value, rb.position_value, self.descending);
                }
                Column::Velocity => return numbers(ra.velocity, rb.velocity, self.descending),
                // Faults first when ascending: what needs a look leads.
                Column::Fault => return faults(ra, rb, self.descending),
                Column::Link => ra.link.cmp(&rb.link),
            };
            let by = if self.descending { by.reverse() } else { by };
            by.then(a.cmp(&b))
        });
        order
    }
}

/// Two numbers in order, an unknown one last whichever way.
fn numbers(a: Option<f64>, b: Option<f64>, descending: bool) -> Ordering {
    match (a, b) {
        (Some(a), Some(b)) => {
            let by = a.total_cmp(&b);
            if descending { by.reverse() } else { by }
        }
        (Some(_), None) => Ordering::Less,
        (None, Some(_)) => Ordering::Greater,
        (None, None) => Ordering::Equal,
    }
}

/// Drives with a fault first (ascending), then by the fault's words.
fn faults(a: &DriveRow, b: &DriveRow, descending: bool) -> Ordering {
    let by = match (&a.fault, &b.fault) {
        (Some(x), Some(y)) => x.cmp(y),
        (Some(_), None) => Ordering::Less,
        (None, Some(_)) => Ordering::Greater,
        (None, None) => Ordering::Equal,
    };
    if descending { by.reverse() } else { by }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ui::glance::model::Tone;

    fn row(name: &str, position: Option<f64>, fault: Option<&str>) -> DriveRow {
        DriveRow {
            name: name.into(),
            color: 0,
            link: "sim".into(),
            state: "Operation enabled".into(),
            tone: Tone::Go,
            fault: fault.map(str::to_owned),
            position: position.map(|p| format!("{p}")),
            position_value: position,
            velocity: None,
            in_plots: false,
            motion: "still".into(),
            connected: true,
            check: None,
        }
    }

    #[test]
    fn sorts_by_a_column_turns_round_on_a_second_click_and_keeps_unknowns_last() {
        let rows = vec![
            row("Y", Some(5.0), None),
            row("x", None, Some("fault 2300h")),
            row("Z", Some(-3.0), None),
        ];
        let mut sort = MachineSort::default();
        assert_eq!(sort.order(&rows), [0, 1, 2]);
        sort.click(Column::Name);
        assert_eq!(sort.order(&rows), [1, 0, 2], "case does not matter");
        sort.click(Column::Name);
        assert_eq!(sort.order(&rows), [2, 0, 1]);
        sort.click(Column::Position);
        assert_eq!(sort.order(&rows), [2, 0, 1], "unknown last");
        sort.click(Column::Position);
        assert_eq!(sort.order(&rows), [0, 2, 1], "unknown last, descending too");
        sort.click(Column::Fault);
        assert_eq!(sort.order(&rows)[0], 1, "the faulted drive leads");
    }
}

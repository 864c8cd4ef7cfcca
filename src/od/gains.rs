//! The closed-loop controller's gains and the limits that shape a response, in the order
//! a technician reads them (protocol notes §4.2.1): what `drivedeck gains` lists and the
//! window's Gains tab shows and edits.

use super::Address;

/// (index, subindices, group), in the order they are listed.
pub const GAINS: [(u16, &[u8], &str); 14] = [
    (
        0x3210,
        &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
        "controller (3210h)",
    ),
    (0x321A, &[1, 2, 3, 4], "controller, newer set"),
    (0x321B, &[1, 2], "controller, newer set"),
    (0x321C, &[1, 2], "controller, newer set"),
    (0x2031, &[0], "limit"),
    (0x203B, &[1, 2], "limit"),
    (0x6073, &[0], "limit"),
    (0x6080, &[0], "limit"),
    (0x607F, &[0], "limit"),
    (0x6083, &[0], "profile"),
    (0x6084, &[0], "profile"),
    (0x6065, &[0], "window"),
    (0x6066, &[0], "window"),
    (0x6067, &[0], "window"),
];

/// Every address listed, in order.
pub fn addresses() -> Vec<Address> {
    GAINS
        .iter()
        .flat_map(|(index, subs, _)| subs.iter().map(|sub| Address::new(*index, *sub)))
        .collect()
}

/// The group an address is listed under ("" for one not listed).
pub fn group_of(address: Address) -> &'static str {
    GAINS
        .iter()
        .find(|(index, ..)| *index == address.index)
        .map_or("", |(_, _, group)| *group)
}

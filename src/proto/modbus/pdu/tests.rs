use proptest::prelude::*;

use super::*;
use crate::cia::AbortCode;

fn bytes(hex: &str) -> Vec<u8> {
    hex.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).expect("test vector is hex"))
        .collect()
}

fn round_trip_request(request: &Request) {
    let pdu = request.encode();
    assert_eq!(Request::decode(&pdu).as_ref(), Ok(request), "{pdu:02X?}");
}

fn round_trip_response(request: &Request, response: &Response) {
    let pdu = response.encode();
    assert_eq!(
        Response::decode(request, &pdu),
        Ok(Ok(response.clone())),
        "{pdu:02X?}"
    );
}

// --- Golden vectors of protocol notes §1.2 ---------------------------------------------

#[test]
fn fc16_od_read_of_3320h_01_matches_the_spec_example() {
    let request = Request::WriteMultiple {
        address: 5996,
        values: vec![0x0000, 0x0000, 0x3320, 0x010E],
    };
    let wire = bytes("10 17 6C 00 04 08 00 00 00 00 33 20 01 0E");
    assert_eq!(request.encode(), wire);
    assert_eq!(Request::decode(&wire), Ok(request.clone()));
    assert_eq!(request.describe(), "FC 16 (write 5996-5999)");
    round_trip_response(
        &request,
        &Response::WriteMultiple {
            address: 5996,
            count: 4,
        },
    );
}

#[test]
fn fc23_pdi_exchange_header_matches_the_register_map() {
    let request = Request::ReadWrite {
        read_address: 4996,
        read_count: 4,
        write_address: 5996,
        values: vec![0x0000, 0x0000, 0x3320, 0x018E],
    };
    let wire = request.encode();
    assert_eq!(wire[..10], bytes("17 13 84 00 04 17 6C 00 04 08")[..]);
    assert_eq!(wire[10..], bytes("00 00 00 00 33 20 01 8E")[..]);
    assert_eq!(
        request.describe(),
        "FC 23 (read 4996-4999, write 5996-5999)"
    );
    let reply = bytes("17 08 00 01 00 00 00 00 01 2C");
    assert_eq!(
        Response::decode(&request, &reply),
        Ok(Ok(Response::ReadWrite(vec![1, 0, 0, 300])))
    );
}

// --- FC 43 / MEI 0Dh ----------------------------------------------------------------

#[test]
fn fc43_read_is_what_public_code_sends() {
    // HAN MotorModbusMaster::sendReadRequest; the same bytes as the N5 manual's example.
    let request = Request::Canopen(CanopenRequest::read(1, 0x6060, 0x00, 2));
    let wire = bytes("2B 0D 00 00 01 60 60 00 00 00 00 02");
    assert_eq!(request.encode(), wire);
    assert_eq!(Request::decode(&wire), Ok(request.clone()));
    assert_eq!(request.describe(), "FC 43 (read 6060h:00, node 1, 2 bytes)");
}

#[test]
fn fc43_write_is_what_public_code_sends() {
    // HAN MotorModbusMaster::sendWriteRequest: control 01h, then the data bytes.
    let request = Request::Canopen(CanopenRequest::write(5, 0x6040, 0x00, vec![0x06, 0x00]));
    let wire = bytes("2B 0D 01 00 05 60 40 00 00 00 00 02 06 00");
    assert_eq!(request.encode(), wire);
    assert_eq!(Request::decode(&wire), Ok(request));
}

#[test]
fn fc43_read_response_carries_the_object_bytes() {
    let request = Request::Canopen(CanopenRequest::read(1, 0x6041, 0x00, 2));
    let wire = bytes("2B 0D 00 00 01 60 41 00 00 00 00 02 37 06");
    let Ok(Ok(Response::Canopen(response))) = Response::decode(&request, &wire) else {
        panic!("not a CANopen response");
    };
    assert_eq!(response.data, vec![0x37, 0x06]);
    assert_eq!(response.header.count, 2);
}

#[test]
fn fc43_write_response_with_or_without_the_data_echo() {
    let asked = CanopenRequest::write(1, 0x6040, 0x00, vec![0x0F, 0x00]);
    let request = Request::Canopen(asked.clone());
    let echoed = bytes("2B 0D 01 00 01 60 40 00 00 00 00 02 0F 00");
    let bare = bytes("2B 0D 01 00 01 60 40 00 00 00 00 02");
    assert_eq!(
        Response::decode(&request, &echoed),
        Ok(Ok(Response::Canopen(CanopenResponse::answering(
            &asked,
            Vec::new()
        ))))
    );
    let Ok(Ok(Response::Canopen(response))) = Response::decode(&request, &bare) else {
        panic!("a write response without data must be accepted");
    };
    assert!(response.data.is_empty());
    // What we send as a server: the full echo.
    assert_eq!(
        Response::Canopen(CanopenResponse::answering(&asked, Vec::new())).encode(),
        echoed
    );
}

#[test]
fn fc43_protocol_control_bits_follow_nanotec_numbering() {
    let header = CanopenHeader {
        write: true,
        extend: true,
        control2: Some(0x00),
        counter: Some(7),
        network_id: Some(1),
        encoded_data: Some(0),
        ..CanopenHeader::default()
    };
    // NT bit 0 (MSB) extend, 1 extended control, 2 counter, 5 network id, 6 encoded
    // data, 7 (LSB) access.
    assert_eq!(header.control(), 0b1110_0111);
    assert_eq!(header.encoded_len(), 2 + 2 + 1 + 3 + 8);
    let request = Request::Canopen(CanopenRequest {
        header: CanopenHeader { count: 1, ..header },
        data: vec![0xAA],
    });
    let wire = request.encode();
    assert_eq!(
        wire,
        bytes("2B 0D E7 00 00 07 01 00 00 00 00 00 00 00 00 01 AA")
    );
    round_trip_request(&request);
}

#[test]
fn fc43_decoder_ignores_reserved_bits_and_byte() {
    let wire = bytes("2B 0D 18 55 01 60 41 00 00 00 00 02");
    assert_eq!(
        Request::decode(&wire),
        Ok(Request::Canopen(CanopenRequest::read(1, 0x6041, 0, 2)))
    );
}

#[test]
fn fc43_with_another_mei_is_other() {
    let wire = bytes("2B 0E 01 00");
    assert_eq!(
        Request::decode(&wire),
        Ok(Request::Other {
            function: 0x2B,
            data: vec![0x0E, 0x01, 0x00]
        })
    );
}

#[test]
fn fc43_errors_name_what_is_wrong() {
    let short_write = bytes("2B 0D 01 00 01 60 40 00 00 00 00 04 06 00");
    assert_eq!(
        Request::decode(&short_write).unwrap_err().to_string(),
        "FC 43 write: the number-of-data field says 4 bytes, but 2 data bytes follow"
    );
    let truncated = bytes("2B 0D 00 00 01 60");
    assert_eq!(
        Request::decode(&truncated).unwrap_err().to_string(),
        "FC 43: the PDU ends after 6 bytes, before the object index"
    );
    let request = Request::Canopen(CanopenRequest::read(1, 0x6041, 0, 2));
    let wrong_object = bytes("2B 0D 00 00 01 60 61 00 00 00 00 01 08");
    assert_eq!(
        Response::decode(&request, &wrong_object)
            .unwrap_err()
            .to_string(),
        "FC 43: the response gives object 6061h:00, the request sent 6041h:00"
    );
    let too_long = CanopenRequest::write(1, 0x2000, 0, vec![0; 250]);
    assert_eq!(
        too_long.validate().unwrap_err().to_string(),
        "FC 43: 250 data bytes do not fit one PDU (at most 241 with this header); split the transfer"
    );
}

// --- Exceptions ---------------------------------------------------------------------

#[test]
fn extended_exception_little_endian_as_in_the_n5_example() {
    // N5 manual: reading 2 bytes of a 1-byte object → 06070012h.
    let request = Request::Canopen(CanopenRequest::read(1, 0x6061, 0, 2));
    let wire = bytes("AB FF 00 06 0D CE 12 00 07 06");
    let refusal = Exception::Extended {
        function: 0x2B,
        abort: 0x0607_0012,
    };
    assert_eq!(Response::decode(&request, &wire), Ok(Err(refusal)));
    assert_eq!(refusal.encode(), wire);
    assert_eq!(
        refusal.text(),
        "Data type does not match, length of service parameter too high"
    );
    assert_eq!(
        refusal.to_string(),
        "FC 43 refused: abort 06070012h (Data type does not match, length of service parameter too high)"
    );
}

#[test]
fn extended_exception_big_endian_is_recognised_when_only_it_is_known() {
    let wire = bytes("AB FF 00 06 0D CE 06 02 00 00");
    assert_eq!(
        Exception::decode(&wire),
        Ok(Exception::Extended {
            function: 0x2B,
            abort: 0x0602_0000
        })
    );
    // Neither reading known: little-endian, shown raw.
    let unknown = bytes("AB FF 00 06 0D CE 78 56 34 12");
    let refusal = Exception::decode(&unknown).expect("well-formed");
    assert_eq!(refusal.abort(), Some(AbortCode(0x1234_5678)));
    assert_eq!(refusal.text(), "not a CiA 301 abort code");
}

#[test]
fn malformed_extended_exception_is_an_error_with_the_bytes() {
    let wire = bytes("AB FF 00 05 0D CE 12 00 07");
    assert_eq!(
        Exception::decode(&wire).unwrap_err().to_string(),
        "FC 43: extended exception not in Nanotec's layout (FF, length 0006h, 0Dh, CEh, 4-byte code): 00 05 0D CE 12 00 07"
    );
}

#[test]
fn standard_exceptions_have_their_texts() {
    let request = Request::ReadHolding {
        address: 4996,
        count: 4,
    };
    let refusal = Exception::Standard {
        function: 3,
        code: 2,
    };
    assert_eq!(
        Response::decode(&request, &bytes("83 02")),
        Ok(Err(refusal))
    );
    assert_eq!(refusal.encode(), bytes("83 02"));
    assert_eq!(
        refusal.to_string(),
        "FC 3 refused: exception 02h, illegal data address"
    );
    let texts: Vec<_> = (1..=4)
        .map(|code| Exception::Standard { function: 3, code }.text())
        .collect();
    assert_eq!(
        texts,
        [
            "illegal function",
            "illegal data address",
            "illegal data value",
            "slave device failure"
        ]
    );
    assert_eq!(
        Exception::Standard {
            function: 3,
            code: 0x42
        }
        .text(),
        "unknown exception code"
    );
    assert_eq!(
        Exception::decode(&bytes("03 02")),
        Err(PduError::NotException(3))
    );
}

// --- FC 101 -------------------------------------------------------------------------

#[test]
fn fc101_reads_the_dictionary_frame_by_frame() {
    let restart = Request::ReadDictionary { restart: true };
    assert_eq!(restart.encode(), bytes("65 55 00"));
    assert_eq!(
        Request::ReadDictionary { restart: false }.encode(),
        bytes("65 AA 00")
    );
    assert_eq!(
        Request::decode(&bytes("65 AA 00")),
        Ok(Request::ReadDictionary { restart: false })
    );
    let wire = bytes("65 55 0E 00 10 00 04 92 01 02 00 41 60 00 02 37 06");
    let expected = Response::Dictionary {
        sub: 0x55,
        frames: vec![
            DictionaryFrame {
                index: 0x1000,
                subindex: 0,
                data: vec![0x92, 0x01, 0x02, 0x00],
            },
            DictionaryFrame {
                index: 0x6041,
                subindex: 0,
                data: vec![0x37, 0x06],
            },
        ],
    };
    assert_eq!(Response::decode(&restart, &wire), Ok(Ok(expected.clone())));
    assert_eq!(expected.encode(), wire);
}

#[test]
fn fc101_ends_with_no_data_available_under_either_function_code() {
    let next = Request::ReadDictionary { restart: false };
    for first in ["E5", "AB"] {
        let wire = bytes(&format!("{first} FF 00 06 0D CE 24 00 00 08"));
        let Ok(Err(refusal)) = Response::decode(&next, &wire) else {
            panic!("end of dictionary not recognised after {first}");
        };
        assert_eq!(refusal.abort(), Some(AbortCode::NO_DATA));
    }
}

#[test]
fn fc101_errors() {
    assert_eq!(
        Request::decode(&bytes("65 12 00")).unwrap_err().to_string(),
        "FC 101: sub-function 12h is neither 55h (restart) nor AAh (next)"
    );
    let next = Request::ReadDictionary { restart: false };
    assert_eq!(
        Response::decode(&next, &bytes("65 AA 05 00 10 00 04"))
            .unwrap_err()
            .to_string(),
        "FC 101: the length byte says 5 bytes follow, but 4 do"
    );
    assert_eq!(
        Response::decode(&next, &bytes("65 AA 05 00 10 00 04 92"))
            .unwrap_err()
            .to_string(),
        "FC 101: the PDU ends after 5 bytes, before the object frame data"
    );
}

// --- Limits and mismatches ----------------------------------------------------------

#[test]
fn quantity_limits_are_checked_both_ways() {
    let cases = [
        (
            Request::ReadHolding {
                address: 0,
                count: 126,
            },
            "FC 3: register count is 126, the Modbus limit is 1 … 125",
        ),
        (
            Request::ReadInput {
                address: 0,
                count: 0,
            },
            "FC 4: register count is 0, the Modbus limit is 1 … 125",
        ),
        (
            Request::WriteMultiple {
                address: 0,
                values: vec![0; 124],
            },
            "FC 16: register count is 124, the Modbus limit is 1 … 123",
        ),
        (
            Request::ReadWrite {
                read_address: 0,
                read_count: 126,
                write_address: 0,
                values: vec![0],
            },
            "FC 23: read count is 126, the Modbus limit is 1 … 125",
        ),
        (
            Request::ReadWrite {
                read_address: 0,
                read_count: 1,
                write_address: 0,
                values: vec![0; 122],
            },
            "FC 23: write count is 122, the Modbus limit is 1 … 121",
        ),
    ];
    for (request, message) in cases {
        assert_eq!(request.validate().unwrap_err().to_string(), message);
        assert_eq!(
            Request::decode(&request.encode()).unwrap_err().to_string(),
            message
        );
    }
    let at_the_limits = [
        Request::ReadHolding {
            address: 0,
            count: 125,
        },
        Request::WriteMultiple {
            address: 0,
            values: vec![0; 123],
        },
        Request::ReadWrite {
            read_address: 0,
            read_count: 125,
            write_address: 0,
            values: vec![0; 121],
        },
    ];
    for request in at_the_limits {
        round_trip_request(&request);
    }
}

#[test]
fn byte_counts_must_be_twice_the_count() {
    let wire = bytes("10 17 6C 00 02 03 00 00 00");
    assert_eq!(
        Request::decode(&wire).unwrap_err().to_string(),
        "FC 16: byte count 3 does not match 2 registers (must be 4)"
    );
    let request = Request::ReadHolding {
        address: 4996,
        count: 2,
    };
    assert_eq!(
        Response::decode(&request, &bytes("03 02 00 01"))
            .unwrap_err()
            .to_string(),
        "FC 3: byte count 2 does not match 2 registers (must be 4)"
    );
    assert_eq!(
        Response::decode(&request, &bytes("03 04 00 01 00"))
            .unwrap_err()
            .to_string(),
        "FC 3: the PDU ends after 5 bytes, before the register values"
    );
    assert_eq!(
        Response::decode(&request, &bytes("03 04 00 01 00 02 FF"))
            .unwrap_err()
            .to_string(),
        "FC 3: 1 unexpected bytes after the response"
    );
}

#[test]
fn responses_must_answer_the_request() {
    let request = Request::ReadInput {
        address: 4996,
        count: 4,
    };
    assert_eq!(
        Response::decode(&request, &bytes("03 02 00 00"))
            .unwrap_err()
            .to_string(),
        "the response to FC 4 (read 4996-4999) has function code 3 (03h)"
    );
    let write = Request::WriteSingle {
        address: 5999,
        value: 0x010E,
    };
    assert_eq!(
        Response::decode(&write, &bytes("06 17 6F 01 0F"))
            .unwrap_err()
            .to_string(),
        "FC 6: the response gives value 271, the request sent 270"
    );
    assert_eq!(write.describe(), "FC 6 (write 5999 = 010Eh)");
    assert_eq!(
        Response::decode(
            &Request::Other {
                function: 8,
                data: vec![]
            },
            &bytes("08 00")
        )
        .unwrap_err()
        .to_string(),
        "FC 8: drivedeck has no decoder for the response to this function code"
    );
    assert_eq!(Response::decode(&write, &[]), Err(PduError::Empty));
    assert_eq!(Request::decode(&[]), Err(PduError::Empty));
}

#[test]
fn describe_is_short() {
    let cases = [
        (
            Request::ReadHolding {
                address: 4996,
                count: 1,
            },
            "FC 3 (read 4996)",
        ),
        (
            Request::ReadDictionary { restart: true },
            "FC 101 (restart)",
        ),
        (
            Request::Other {
                function: 0x2B,
                data: vec![0x0E, 1, 0],
            },
            "FC 43 (3 data bytes)",
        ),
    ];
    for (request, text) in cases {
        assert_eq!(request.describe(), text);
    }
}

// --- Property tests -----------------------------------------------------------------

fn any_header(write: bool) -> impl Strategy<Value = CanopenHeader> {
    (
        (any::<bool>(), proptest::option::of(any::<u8>())),
        proptest::option::of(any::<u8>()),
        proptest::option::of(any::<u8>()),
        proptest::option::of(any::<u8>()),
        (
            any::<u8>(),
            any::<u16>(),
            any::<u8>(),
            any::<u16>(),
            any::<u16>(),
        ),
    )
        .prop_map(
            move |(
                (extend, control2),
                counter,
                network_id,
                encoded_data,
                (node_id, index, subindex, start, count),
            )| CanopenHeader {
                write,
                extend,
                control2,
                counter,
                network_id,
                encoded_data,
                node_id,
                index,
                subindex,
                start,
                count,
            },
        )
}

fn any_canopen_request() -> impl Strategy<Value = CanopenRequest> {
    any::<bool>()
        .prop_flat_map(any_header)
        .prop_flat_map(|header| {
            let len = if header.write {
                0..=header.max_data()
            } else {
                0..=0
            };
            (Just(header), proptest::collection::vec(any::<u8>(), len))
        })
        .prop_map(|(mut header, data)| {
            if header.write {
                header.count = saturating_u16(data.len());
            }
            CanopenRequest { header, data }
        })
}

fn registers_up_to(max: u16) -> impl Strategy<Value = Vec<u16>> {
    proptest::collection::vec(any::<u16>(), 1..=usize::from(max))
}

const KNOWN: [u8; 7] = [0x03, 0x04, 0x06, 0x10, 0x17, 0x2B, 0x65];

/// Valid requests of every kind.
pub(crate) fn any_request() -> impl Strategy<Value = Request> {
    prop_oneof![
        (any::<u16>(), 1..=limits::READ_MAX)
            .prop_map(|(address, count)| Request::ReadHolding { address, count }),
        (any::<u16>(), 1..=limits::READ_MAX)
            .prop_map(|(address, count)| Request::ReadInput { address, count }),
        (any::<u16>(), any::<u16>())
            .prop_map(|(address, value)| Request::WriteSingle { address, value }),
        (any::<u16>(), registers_up_to(limits::WRITE_MULTIPLE_MAX))
            .prop_map(|(address, values)| Request::WriteMultiple { address, values }),
        (
            any::<u16>(),
            1..=limits::READ_MAX,
            any::<u16>(),
            registers_up_to(limits::READ_WRITE_WRITE_MAX)
        )
            .prop_map(|(read_address, read_count, write_address, values)| {
                Request::ReadWrite {
                    read_address,
                    read_count,
                    write_address,
                    values,
                }
            }),
        any_canopen_request().prop_map(Request::Canopen),
        any::<bool>().prop_map(|restart| Request::ReadDictionary { restart }),
        (
            any::<u8>().prop_filter("unknown function", |f| !KNOWN.contains(f)),
            proptest::collection::vec(any::<u8>(), 0..MAX_PDU)
        )
            .prop_map(|(function, data)| Request::Other { function, data }),
        proptest::collection::vec(any::<u8>(), 0..8).prop_map(|mut data| {
            data.insert(0, MEI_DEVICE_ID);
            Request::Other {
                function: fc::ENCAPSULATED,
                data,
            }
        }),
    ]
}

fn any_frames() -> impl Strategy<Value = Vec<DictionaryFrame>> {
    proptest::collection::vec(
        (
            any::<u16>(),
            any::<u8>(),
            proptest::collection::vec(any::<u8>(), 0..=8),
        )
            .prop_map(|(index, subindex, data)| DictionaryFrame {
                index,
                subindex,
                data,
            }),
        0..=20,
    )
}

/// A valid request with a valid normal response to it.
pub(crate) fn any_exchange() -> impl Strategy<Value = (Request, Response)> {
    any_request()
        .prop_filter("has a response decoder", |r| {
            !matches!(r, Request::Other { .. })
        })
        .prop_flat_map(|request| {
            let response = match &request {
                Request::ReadHolding { count, .. } => {
                    proptest::collection::vec(any::<u16>(), usize::from(*count))
                        .prop_map(Response::ReadHolding)
                        .boxed()
                }
                Request::ReadInput { count, .. } => {
                    proptest::collection::vec(any::<u16>(), usize::from(*count))
                        .prop_map(Response::ReadInput)
                        .boxed()
                }
                Request::ReadWrite { read_count, .. } => {
                    proptest::collection::vec(any::<u16>(), usize::from(*read_count))
                        .prop_map(Response::ReadWrite)
                        .boxed()
                }
                Request::WriteSingle { address, value } => Just(Response::WriteSingle {
                    address: *address,
                    value: *value,
                })
                .boxed(),
                Request::WriteMultiple { address, values } => Just(Response::WriteMultiple {
                    address: *address,
                    count: saturating_u16(values.len()),
                })
                .boxed(),
                Request::Canopen(asked) => {
                    let asked = asked.clone();
                    proptest::collection::vec(any::<u8>(), 0..=asked.header.max_data())
                        .prop_map(move |data| {
                            Response::Canopen(CanopenResponse::answering(&asked, data))
                        })
                        .boxed()
                }
                Request::ReadDictionary { restart } => {
                    let sub = if *restart {
                        DICTIONARY_RESTART
                    } else {
                        DICTIONARY_NEXT
                    };
                    any_frames()
                        .prop_map(move |frames| Response::Dictionary { sub, frames })
                        .boxed()
                }
                Request::Other { .. } => unreachable!("filtered out"),
            };
            (Just(request), response)
        })
}

pub(crate) fn any_exception() -> impl Strategy<Value = Exception> {
    prop_oneof![
        (0u8..0x80, 1u8..=0x0B).prop_map(|(function, code)| Exception::Standard { function, code }),
        (
            prop_oneof![
                Just(fc::ENCAPSULATED),
                Just(fc::READ_DICTIONARY),
                Just(fc::READ_ARRAY)
            ],
            prop_oneof![
                Just(AbortCode::NO_OBJECT.0),
                Just(AbortCode::NO_DATA.0),
                Just(AbortCode::TYPE_LENGTH_TOO_HIGH.0)
            ]
        )
            .prop_map(|(function, abort)| Exception::Extended { function, abort }),
    ]
}

proptest! {
    #[test]
    fn request_decoder_is_total(pdu in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = Request::decode(&pdu);
        let _ = Exception::decode(&pdu);
    }

    #[test]
    fn response_decoder_is_total(
        request in any_request(),
        pdu in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let _ = Response::decode(&request, &pdu);
    }

    #[test]
    fn response_decoder_is_total_on_near_misses(
        (request, response) in any_exchange(),
        flip in any::<(usize, u8)>(),
        cut in any::<usize>(),
    ) {
        let mut pdu = response.encode();
        let at = flip.0 % pdu.len();
        pdu[at] ^= flip.1;
        let _ = Response::decode(&request, &pdu);
        pdu.truncate(cut % (pdu.len() + 1));
        let _ = Response::decode(&request, &pdu);
    }

    #[test]
    fn requests_round_trip(request in any_request()) {
        prop_assert_eq!(request.validate(), Ok(()));
        prop_assert!(request.encode().len() <= MAX_PDU);
        round_trip_request(&request);
    }

    #[test]
    fn responses_round_trip((request, response) in any_exchange()) {
        prop_assert!(response.encode().len() <= MAX_PDU);
        round_trip_response(&request, &response);
    }

    #[test]
    fn exceptions_round_trip(refusal in any_exception()) {
        prop_assert_eq!(Exception::decode(&refusal.encode()), Ok(refusal));
    }
}

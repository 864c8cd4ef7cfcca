use std::collections::BTreeMap;

use proptest::prelude::*;

use super::*;

/// An object of the fake dictionary: value, fixed size (`None` = any), writable.
type FakeObject = (Vec<u8>, Option<usize>, bool);

/// A fake object dictionary: fixed-size objects check the length.
#[derive(Default)]
struct FakeOd {
    objects: BTreeMap<(u16, u8), FakeObject>,
    writes: Vec<(u16, u8, Vec<u8>)>,
}

impl FakeOd {
    fn new() -> Self {
        let mut od = FakeOd::default();
        od.add(0x1018, 0x01, &0x0000_026Cu32.to_le_bytes(), Some(4), false);
        od.add(0x1017, 0x00, &[0, 0], Some(2), true);
        od.add(0x6040, 0x00, &[0, 0], Some(2), true);
        od.add(0x1008, 0x00, b"PD4-C5918L4204-E-08 (CAN)", None, false);
        od.add(0x2400, 0x01, &[], None, true);
        od
    }

    fn add(&mut self, index: u16, sub: u8, data: &[u8], size: Option<usize>, rw: bool) {
        self.objects.insert((index, sub), (data.to_vec(), size, rw));
    }
}

impl ObjectAccess for FakeOd {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        match self.objects.get(&(index, sub)) {
            Some((data, _, _)) => Ok(data.clone()),
            None if self.objects.keys().any(|(i, _)| *i == index) => Err(AbortCode::NO_SUBINDEX),
            None => Err(AbortCode::NO_OBJECT),
        }
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let Some((value, size, rw)) = self.objects.get_mut(&(index, sub)) else {
            return Err(AbortCode::NO_OBJECT);
        };
        if !*rw {
            return Err(AbortCode::READ_ONLY);
        }
        if size.is_some_and(|s| s != data.len()) {
            return Err(AbortCode::TYPE_LENGTH_MISMATCH);
        }
        *value = data.to_vec();
        self.writes.push((index, sub, data.to_vec()));
        Ok(())
    }
}

fn req(bytes: [u8; 8]) -> CanFrame {
    CanFrame::new(0x601, &bytes).unwrap()
}

fn resp(bytes: [u8; 8]) -> CanFrame {
    CanFrame::new(0x581, &bytes).unwrap()
}

fn abort_bytes(index: u16, sub: u8, code: AbortCode) -> [u8; 8] {
    Response::Abort { index, sub, code }.encode()
}

/// Run a transfer between client and server until the client reports an outcome.
fn run(
    client: &mut SdoClient,
    server: &mut SdoServer,
    od: &mut FakeOd,
    first: CanFrame,
) -> SdoEvent {
    let mut request = first;
    for _ in 0..10_000 {
        let Some(response) = server.on_request(&request, od) else {
            return SdoEvent::Ignored;
        };
        match client.on_frame(&response) {
            SdoEvent::Send(next) => request = next,
            outcome => return outcome,
        }
    }
    panic!("transfer did not end");
}

#[test]
fn reading_1018_01_byte_for_byte() {
    let mut client = SdoClient::new(1);
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let request = client.upload(0x1018, 0x01);
    assert_eq!(request, req([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
    let response = server.on_request(&request, &mut od).unwrap();
    assert_eq!(
        response,
        resp([0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0x00, 0x00])
    );
    assert_eq!(
        client.on_frame(&response),
        SdoEvent::Uploaded(vec![0x6C, 0x02, 0, 0])
    );
    assert!(!client.is_busy());
}

#[test]
fn expedited_sizes_and_unindicated_size() {
    for (byte0, len) in [(0x4F, 1), (0x4B, 2), (0x47, 3), (0x43, 4), (0x42, 4)] {
        let mut client = SdoClient::new(1);
        client.upload(0x2000, 0);
        let frame = resp([byte0, 0x00, 0x20, 0x00, 1, 2, 3, 4]);
        assert_eq!(
            client.on_frame(&frame),
            SdoEvent::Uploaded(vec![1, 2, 3, 4][..len].to_vec()),
            "{byte0:02X}"
        );
    }
    let mut od = FakeOd::new();
    od.add(0x2000, 1, &[7], Some(1), true);
    od.add(0x2000, 3, &[7, 8, 9], Some(3), true);
    let mut server = SdoServer::new(1);
    let r = server
        .on_request(&req([0x40, 0x00, 0x20, 1, 0, 0, 0, 0]), &mut od)
        .unwrap();
    assert_eq!(r, resp([0x4F, 0x00, 0x20, 1, 7, 0, 0, 0]));
    let r = server
        .on_request(&req([0x40, 0x00, 0x20, 3, 0, 0, 0, 0]), &mut od)
        .unwrap();
    assert_eq!(r, resp([0x47, 0x00, 0x20, 3, 7, 8, 9, 0]));
}

#[test]
fn writing_a_u16_byte_for_byte() {
    let mut client = SdoClient::new(1);
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let request = client.download(0x6040, 0x00, &0x000Fu16.to_le_bytes());
    assert_eq!(request, req([0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0, 0]));
    let response = server.on_request(&request, &mut od).unwrap();
    assert_eq!(response, resp([0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0]));
    assert_eq!(client.on_frame(&response), SdoEvent::Downloaded);
    assert_eq!(od.writes, vec![(0x6040, 0, vec![0x0F, 0x00])]);
    // The other expedited sizes.
    assert_eq!(client.download(0x2000, 1, &[1]).data()[0], 0x2F);
    assert_eq!(client.download(0x2000, 1, &[1, 2, 3]).data()[0], 0x27);
    assert_eq!(
        client.download(0x2000, 1, &[1, 2, 3, 4]),
        req([0x23, 0x00, 0x20, 0x01, 1, 2, 3, 4])
    );
}

#[test]
fn segmented_upload_of_25_bytes_in_4_segments() {
    let mut client = SdoClient::new(1);
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let name = b"PD4-C5918L4204-E-08 (CAN)";
    assert_eq!(name.len(), 25);

    let request = client.upload(0x1008, 0x00);
    let response = server.on_request(&request, &mut od).unwrap();
    assert_eq!(response, resp([0x41, 0x08, 0x10, 0x00, 25, 0, 0, 0]));
    let mut want_requests = vec![
        [0x60, 0, 0, 0, 0, 0, 0, 0],
        [0x70, 0, 0, 0, 0, 0, 0, 0],
        [0x60, 0, 0, 0, 0, 0, 0, 0],
        [0x70, 0, 0, 0, 0, 0, 0, 0],
    ]
    .into_iter();
    let mut want_responses = vec![
        [0x00, b'P', b'D', b'4', b'-', b'C', b'5', b'9'],
        [0x10, b'1', b'8', b'L', b'4', b'2', b'0', b'4'],
        [0x00, b'-', b'E', b'-', b'0', b'8', b' ', b'('],
        // t = 1, n = 3 unused, c = 1.
        [0x17, b'C', b'A', b'N', b')', 0, 0, 0],
    ]
    .into_iter();
    let mut event = client.on_frame(&response);
    while let SdoEvent::Send(request) = event {
        assert_eq!(request, req(want_requests.next().unwrap()));
        let response = server.on_request(&request, &mut od).unwrap();
        assert_eq!(response, resp(want_responses.next().unwrap()));
        event = client.on_frame(&response);
    }
    assert_eq!(event, SdoEvent::Uploaded(name.to_vec()));
    assert!(want_requests.next().is_none() && want_responses.next().is_none());
    assert!(!server.is_busy());
}

#[test]
fn segmented_download_of_10_bytes() {
    let mut client = SdoClient::new(1);
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let data = b"0123456789";
    let request = client.download(0x2400, 0x01, data);
    assert_eq!(request, req([0x21, 0x00, 0x24, 0x01, 10, 0, 0, 0]));
    let response = server.on_request(&request, &mut od).unwrap();
    assert_eq!(response, resp([0x60, 0x00, 0x24, 0x01, 0, 0, 0, 0]));
    let SdoEvent::Send(first) = client.on_frame(&response) else {
        panic!("no first segment")
    };
    assert_eq!(first, req([0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']));
    let response = server.on_request(&first, &mut od).unwrap();
    assert_eq!(response, resp([0x20, 0, 0, 0, 0, 0, 0, 0]));
    let SdoEvent::Send(second) = client.on_frame(&response) else {
        panic!("no second segment")
    };
    // t = 1, n = 4 unused, c = 1.
    assert_eq!(second, req([0x19, b'7', b'8', b'9', 0, 0, 0, 0]));
    let response = server.on_request(&second, &mut od).unwrap();
    assert_eq!(response, resp([0x30, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(client.on_frame(&response), SdoEvent::Downloaded);
    assert_eq!(od.writes, vec![(0x2400, 1, data.to_vec())]);
}

#[test]
fn empty_values_go_segmented() {
    let mut client = SdoClient::new(1);
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let first = client.download(0x2400, 1, &[]);
    assert_eq!(first, req([0x21, 0x00, 0x24, 0x01, 0, 0, 0, 0]));
    assert_eq!(
        run(&mut client, &mut server, &mut od, first),
        SdoEvent::Downloaded
    );
    let first = client.upload(0x2400, 1);
    assert_eq!(
        run(&mut client, &mut server, &mut od, first),
        SdoEvent::Uploaded(vec![])
    );
}

#[test]
fn server_abort_paths() {
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let mut ask = |bytes: [u8; 8]| server.on_request(&req(bytes), &mut od);
    // Object and sub-index that do not exist.
    assert_eq!(
        ask([0x40, 0x34, 0x12, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(0x1234, 0, AbortCode::NO_OBJECT)))
    );
    assert_eq!(
        ask([0x40, 0x18, 0x10, 9, 0, 0, 0, 0]),
        Some(resp([0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06]))
    );
    // Read-only, wrong length.
    assert_eq!(
        ask([0x23, 0x18, 0x10, 1, 1, 2, 3, 4]),
        Some(resp(abort_bytes(0x1018, 1, AbortCode::READ_ONLY)))
    );
    assert_eq!(
        ask([0x2F, 0x40, 0x60, 0, 1, 0, 0, 0]),
        Some(resp(abort_bytes(
            0x6040,
            0,
            AbortCode::TYPE_LENGTH_MISMATCH
        )))
    );
    // Segments without a transfer.
    assert_eq!(
        ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(
            0,
            0,
            AbortCode::INVALID_COMMAND_SPECIFIER
        )))
    );
    assert_eq!(
        ask([0x00, 1, 2, 3, 4, 5, 6, 7]),
        Some(resp(abort_bytes(
            0,
            0,
            AbortCode::INVALID_COMMAND_SPECIFIER
        )))
    );
    // Block upload, block download, ccs 7.
    for byte0 in [0xA0, 0xC0, 0xE0] {
        assert_eq!(
            ask([byte0, 0x08, 0x10, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(
                0x1008,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
    }
    // Wrong toggle in an upload: the first request must carry t = 0.
    assert_eq!(
        ask([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]).map(|f| f.data()[0]),
        Some(0x41)
    );
    assert_eq!(
        ask([0x70, 0, 0, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(
            0x1008,
            0,
            AbortCode::TOGGLE_BIT_NOT_ALTERNATED
        )))
    );
    // The abort ended the transfer.
    assert_eq!(
        ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(
            0,
            0,
            AbortCode::INVALID_COMMAND_SPECIFIER
        )))
    );
    // Wrong toggle in a download.
    assert!(ask([0x21, 0x00, 0x24, 1, 10, 0, 0, 0]).is_some());
    assert_eq!(
        ask([0x10, 1, 2, 3, 4, 5, 6, 7]),
        Some(resp(abort_bytes(
            0x2400,
            1,
            AbortCode::TOGGLE_BIT_NOT_ALTERNATED
        )))
    );
    // More and fewer bytes than announced.
    assert!(ask([0x21, 0x00, 0x24, 1, 3, 0, 0, 0]).is_some());
    assert_eq!(
        ask([0x01, 1, 2, 3, 4, 5, 6, 7]),
        Some(resp(abort_bytes(
            0x2400,
            1,
            AbortCode::TYPE_LENGTH_TOO_HIGH
        )))
    );
    assert!(ask([0x21, 0x00, 0x24, 1, 9, 0, 0, 0]).is_some());
    assert_eq!(
        ask([0x01, 1, 2, 3, 4, 5, 6, 7]),
        Some(resp(abort_bytes(0x2400, 1, AbortCode::TYPE_LENGTH_TOO_LOW)))
    );
    // Segmented download into a read-only object: aborted when the data is complete.
    assert!(ask([0x21, 0x08, 0x10, 0, 1, 0, 0, 0]).is_some());
    assert_eq!(
        ask([0x0D, b'x', 0, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(0x1008, 0, AbortCode::READ_ONLY)))
    );
    // A client abort ends a transfer without an answer.
    assert!(ask([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]).is_some());
    assert_eq!(
        ask(abort_frame(1, 0x1008, 0, AbortCode::SDO_TIMEOUT)
            .data()
            .try_into()
            .unwrap()),
        None
    );
    assert_eq!(
        ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some(resp(abort_bytes(
            0,
            0,
            AbortCode::INVALID_COMMAND_SPECIFIER
        )))
    );
    // An empty frame is answered with an abort too.
    assert_eq!(
        server.on_request(&CanFrame::new(0x601, &[]).unwrap(), &mut od),
        Some(resp(abort_bytes(
            0,
            0,
            AbortCode::INVALID_COMMAND_SPECIFIER
        )))
    );
    // Frames for other nodes and other services are not answered.
    assert_eq!(
        server.on_request(
            &CanFrame::new(0x602, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
            &mut od
        ),
        None
    );
    assert_eq!(
        server.on_request(
            &CanFrame::new(0x581, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
            &mut od
        ),
        None
    );
    assert_eq!(
        server.on_request(&CanFrame::remote(0x601, 8).unwrap(), &mut od),
        None
    );
}

#[test]
fn a_new_initiate_restarts_the_server() {
    let mut server = SdoServer::new(1);
    let mut od = FakeOd::new();
    let upload = req([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]);
    server.on_request(&upload, &mut od).unwrap();
    server
        .on_request(&req([0x60, 0, 0, 0, 0, 0, 0, 0]), &mut od)
        .unwrap();
    // Restart: the toggle starts at 0 again and the data from the start.
    server.on_request(&upload, &mut od).unwrap();
    let r = server
        .on_request(&req([0x60, 0, 0, 0, 0, 0, 0, 0]), &mut od)
        .unwrap();
    assert_eq!(r, resp([0x00, b'P', b'D', b'4', b'-', b'C', b'5', b'9']));
    // An expedited read in between ends the segmented one.
    server
        .on_request(&req([0x40, 0x18, 0x10, 1, 0, 0, 0, 0]), &mut od)
        .unwrap();
    assert!(!server.is_busy());
}

#[test]
fn client_abort_paths() {
    // The server's abort.
    let mut client = SdoClient::new(1);
    client.upload(0x1018, 9);
    let abort = resp(abort_bytes(0x1018, 9, AbortCode::NO_SUBINDEX));
    assert_eq!(
        client.on_frame(&abort),
        SdoEvent::Aborted(AbortCode::NO_SUBINDEX)
    );
    assert!(!client.is_busy());
    assert_eq!(client.take_abort(), None);
    // A late frame after the end is not ours.
    assert_eq!(client.on_frame(&abort), SdoEvent::Ignored);

    // Timeout: the caller aborts with 05040000h.
    client.upload(0x1018, 1);
    assert_eq!(
        client.abort(AbortCode::SDO_TIMEOUT),
        Some(req([0x80, 0x18, 0x10, 0x01, 0x00, 0x00, 0x04, 0x05]))
    );
    assert_eq!(client.abort(AbortCode::SDO_TIMEOUT), None);
    assert_eq!(
        abort_frame(1, 0x1018, 1, AbortCode::SDO_TIMEOUT),
        req([0x80, 0x18, 0x10, 0x01, 0x00, 0x00, 0x04, 0x05])
    );

    // An answer naming another object: a late answer to an earlier request, skipped; the
    // transfer still takes its own answer.
    client.upload(0x1018, 1);
    let wrong = resp([0x43, 0x18, 0x10, 0x02, 1, 0, 0, 0]);
    let SdoEvent::Stale(message) = client.on_frame(&wrong) else {
        panic!("echo not checked")
    };
    assert!(
        message.contains("1018h:02h") && message.contains("1018h:01h"),
        "{message}"
    );
    assert!(client.is_busy());
    assert_eq!(client.take_abort(), None);
    assert_eq!(
        client.on_frame(&resp([0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0, 0])),
        SdoEvent::Uploaded(vec![0x6C, 0x02, 0, 0])
    );
    client.download(0x6040, 0, &[6, 0]);
    let wrong = resp([0x60, 0x41, 0x60, 0x00, 0, 0, 0, 0]);
    assert!(matches!(client.on_frame(&wrong), SdoEvent::Stale(_)));
    assert_eq!(
        client.on_frame(&resp([0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0])),
        SdoEvent::Downloaded
    );
    // A segmented download waits for its own initiate answer too.
    client.download(0x2400, 1, b"0123456789");
    assert!(matches!(
        client.on_frame(&resp([0x60, 0x00, 0x24, 2, 0, 0, 0, 0])),
        SdoEvent::Stale(_)
    ));
    assert!(matches!(
        client.on_frame(&resp([0x60, 0x00, 0x24, 1, 0, 0, 0, 0])),
        SdoEvent::Send(_)
    ));

    // Wrong toggle in an upload segment.
    client.upload(0x1008, 0);
    let SdoEvent::Send(_) = client.on_frame(&resp([0x41, 0x08, 0x10, 0, 25, 0, 0, 0])) else {
        panic!()
    };
    let SdoEvent::Protocol(message) = client.on_frame(&resp([0x10, 1, 2, 3, 4, 5, 6, 7])) else {
        panic!("toggle not checked")
    };
    assert!(message.contains("toggle"), "{message}");
    assert_eq!(
        client.take_abort(),
        Some(req(with_multiplexer(
            0x80,
            0x1008,
            0,
            AbortCode::TOGGLE_BIT_NOT_ALTERNATED.0.to_le_bytes()
        )))
    );

    // Wrong toggle in a download segment acknowledgement.
    client.download(0x2400, 1, b"0123456789");
    let SdoEvent::Send(_) = client.on_frame(&resp([0x60, 0x00, 0x24, 1, 0, 0, 0, 0])) else {
        panic!()
    };
    assert!(matches!(
        client.on_frame(&resp([0x30, 0, 0, 0, 0, 0, 0, 0])),
        SdoEvent::Protocol(_)
    ));

    // Unexpected command specifier: a download answer to an upload.
    client.upload(0x1018, 1);
    assert!(matches!(
        client.on_frame(&resp([0x60, 0x18, 0x10, 1, 0, 0, 0, 0])),
        SdoEvent::Protocol(_)
    ));
    assert_eq!(
        client.take_abort().map(|f| f.data()[4..].to_vec()),
        Some(
            AbortCode::INVALID_COMMAND_SPECIFIER
                .0
                .to_le_bytes()
                .to_vec()
        )
    );

    // More segment data than announced, and less.
    client.upload(0x1008, 0);
    client.on_frame(&resp([0x41, 0x08, 0x10, 0, 3, 0, 0, 0]));
    assert!(matches!(
        client.on_frame(&resp([0x00, 1, 2, 3, 4, 5, 6, 7])),
        SdoEvent::Protocol(_)
    ));
    client.upload(0x1008, 0);
    client.on_frame(&resp([0x41, 0x08, 0x10, 0, 9, 0, 0, 0]));
    assert!(matches!(
        client.on_frame(&resp([0x0B, 1, 2, 0, 0, 0, 0, 0])),
        SdoEvent::Protocol(_)
    ));

    // An announced size beyond the limit.
    client.upload(0x1008, 0);
    assert!(matches!(
        client.on_frame(&resp([0x41, 0x08, 0x10, 0, 0xFF, 0xFF, 0xFF, 0xFF])),
        SdoEvent::Protocol(_)
    ));
    assert_eq!(
        client.take_abort().map(|f| f.data()[4..].to_vec()),
        Some(AbortCode::OUT_OF_MEMORY.0.to_le_bytes().to_vec())
    );

    // An empty response.
    client.upload(0x1018, 1);
    assert!(matches!(
        client.on_frame(&CanFrame::new(0x581, &[]).unwrap()),
        SdoEvent::Protocol(_)
    ));

    // Frames of other nodes and services are not ours; the transfer goes on.
    client.upload(0x1018, 1);
    let answer = [0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0x00, 0x00];
    assert_eq!(
        client.on_frame(&CanFrame::new(0x582, &answer).unwrap()),
        SdoEvent::Ignored
    );
    assert_eq!(
        client.on_frame(&CanFrame::new(0x601, &answer).unwrap()),
        SdoEvent::Ignored
    );
    assert_eq!(
        client.on_frame(&resp(answer)),
        SdoEvent::Uploaded(vec![0x6C, 0x02, 0, 0])
    );
}

#[test]
fn segmented_upload_without_size_and_short_frames() {
    let mut client = SdoClient::new(1);
    client.upload(0x1008, 0);
    let SdoEvent::Send(r) = client.on_frame(&resp([0x40, 0x08, 0x10, 0, 0, 0, 0, 0])) else {
        panic!()
    };
    assert_eq!(r.data()[0], 0x60);
    // A last segment with DLC 3 (n = 5 unused).
    let short = CanFrame::new(0x581, &[0x0B, b'h', b'i']).unwrap();
    assert_eq!(client.on_frame(&short), SdoEvent::Uploaded(b"hi".to_vec()));
}

#[test]
fn codec_round_trips() {
    let requests = [
        Request::InitiateUpload {
            index: 0x1018,
            sub: 1,
        },
        Request::UploadSegment { toggle: true },
        Request::DownloadSegment(Segment::new(true, &[1, 2, 3], true)),
        Request::InitiateDownload {
            index: 0x6040,
            sub: 0,
            initiate: Initiate::expedited(&[6, 0]).unwrap(),
        },
        Request::InitiateDownload {
            index: 0x6040,
            sub: 0,
            initiate: Initiate::Segmented { size: None },
        },
        Request::Abort {
            index: 1,
            sub: 2,
            code: AbortCode::GENERAL_ERROR,
        },
    ];
    for r in requests {
        assert_eq!(Request::decode(&r.encode()), Ok(r));
    }
    assert_eq!(Request::decode(&[]), Err(SdoError::Empty));
    assert_eq!(Response::decode(&[0; 9]), Err(SdoError::TooLong(9)));
}

proptest! {
    #[test]
    fn server_never_panics(
        frames in proptest::collection::vec(
            (prop_oneof![Just(0x601u16), 0u16..0x800], proptest::collection::vec(any::<u8>(), 0..=8)),
            1..40,
        )
    ) {
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        for (id, data) in frames {
            let frame = CanFrame::new(id, &data).unwrap();
            if let Some(answer) = server.on_request(&frame, &mut od) {
                prop_assert_eq!(answer.cob_id(), Some(0x581));
                prop_assert_eq!(answer.len(), 8);
            }
        }
    }

    #[test]
    fn client_never_panics(
        start in 0u8..3,
        len in 0usize..40,
        frames in proptest::collection::vec(
            (prop_oneof![Just(0x581u16), 0u16..0x800], proptest::collection::vec(any::<u8>(), 0..=8)),
            1..40,
        )
    ) {
        let mut client = SdoClient::new(1);
        let data = vec![0xA5; len];
        for (id, bytes) in frames {
            if !client.is_busy() {
                match start {
                    0 => { client.upload(0x1008, 0); }
                    1 => { client.download(0x2400, 1, &data); }
                    _ => { let _ = client.take_abort(); }
                }
            }
            let frame = CanFrame::new(id, &bytes).unwrap();
            if let SdoEvent::Send(next) = client.on_frame(&frame) {
                prop_assert_eq!(next.cob_id(), Some(0x601));
                prop_assert_eq!(next.len(), 8);
            }
        }
    }

    #[test]
    fn client_and_server_round_trip(data in proptest::collection::vec(any::<u8>(), 0..=300)) {
        let mut client = SdoClient::new(5);
        let mut server = SdoServer::new(5);
        let mut od = FakeOd::new();
        od.add(0x2400, 1, &[], None, true);
        let first = client.download(0x2400, 1, &data);
        prop_assert_eq!(run(&mut client, &mut server, &mut od, first), SdoEvent::Downloaded);
        let first = client.upload(0x2400, 1);
        prop_assert_eq!(run(&mut client, &mut server, &mut od, first), SdoEvent::Uploaded(data));
        prop_assert!(!client.is_busy());
        prop_assert!(!server.is_busy());
    }
}

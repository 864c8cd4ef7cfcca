//! The sans-IO codecs, frames per second encoded and decoded: what one PDI cycle or one
//! object access costs in our own code, apart from any transport.
//!
//! `cargo bench --bench codecs` (criterion prints time per iteration and elements/s).

// A bench may panic: a set-up that fails ends it (clippy.toml covers only tests).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use drivedeck::pdi::{RxImage, TxImage};
use drivedeck::proto::canopen::{CanFrame, sdo, slcan};
use drivedeck::proto::enip::{cpf, encap, io};
use drivedeck::proto::modbus::{frame, pdu};

fn modbus(c: &mut Criterion) {
    let mut g = c.benchmark_group("modbus");
    g.throughput(Throughput::Elements(1));
    // The PDI cycle: FC 23 writing 5996..5999 and reading 4996..4999, in a TCP frame.
    let request = pdu::Request::ReadWrite {
        read_address: 4996,
        read_count: 4,
        write_address: 5996,
        values: vec![0x0000, 0x07D0, 0x00C8, 0x0014],
    };
    g.bench_function("FC 23 request encode (PDU + MBAP)", |b| {
        b.iter(|| frame::encode_tcp(black_box(7), 0, &black_box(&request).encode()))
    });
    let wire = frame::encode_tcp(7, 0, &request.encode());
    g.bench_function("FC 23 request decode (MBAP + PDU)", |b| {
        b.iter(|| {
            let (f, _) = frame::decode_tcp(black_box(&wire))
                .ok()
                .flatten()
                .expect("a frame");
            pdu::Request::decode(&f.pdu).expect("a request")
        })
    });
    let reply = [0x17, 0x08, 0x80, 0x27, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];
    g.bench_function("FC 23 response decode", |b| {
        b.iter(|| pdu::Response::decode(black_box(&request), black_box(&reply)))
    });
    let rtu = frame::encode_rtu(5, &request.encode());
    g.bench_function("FC 23 RTU frame encode (CRC)", |b| {
        b.iter(|| frame::encode_rtu(black_box(5), &black_box(&request).encode()))
    });
    g.bench_function("FC 23 RTU frame decode (CRC)", |b| {
        b.iter(|| frame::decode_rtu(black_box(&rtu), frame::Direction::Request))
    });
    g.finish();
}

fn canopen(c: &mut Criterion) {
    let mut g = c.benchmark_group("canopen");
    g.throughput(Throughput::Elements(1));
    let upload = sdo::Request::InitiateUpload {
        index: 0x6064,
        sub: 0,
    };
    g.bench_function("SDO upload request encode", |b| {
        b.iter(|| black_box(&upload).encode())
    });
    let answer = [0x43, 0x64, 0x60, 0x00, 0xD0, 0x07, 0x00, 0x00];
    g.bench_function("SDO expedited response decode", |b| {
        b.iter(|| sdo::Response::decode(black_box(&answer)))
    });
    let frame = CanFrame::new(0x581, &answer).expect("a frame");
    g.bench_function("slcan line encode", |b| {
        b.iter(|| slcan::encode_frame(black_box(&frame)))
    });
    let line = slcan::encode_frame(&frame);
    let line = line.strip_suffix(b"\r").unwrap_or(&line).to_vec();
    g.bench_function("slcan line decode", |b| {
        b.iter(|| slcan::decode_line(black_box(&line)))
    });
    g.finish();
}

fn enip(c: &mut Criterion) {
    let mut g = c.benchmark_group("enip");
    g.throughput(Throughput::Elements(1));
    // One class 1 packet of the PDI set (8 bytes, run/idle header O->T).
    let packet = io::IoPacket {
        connection: 0x1234_5678,
        sequence: 42,
        count: 7,
        run: Some(true),
        data: vec![0xD0, 0x07, 0, 0, 0xC8, 0, 0, 0x14],
    };
    g.bench_function("class 1 I/O packet encode", |b| {
        b.iter(|| black_box(&packet).encode())
    });
    let bytes = packet.encode();
    g.bench_function("class 1 I/O packet decode", |b| {
        b.iter(|| io::IoPacket::decode(black_box(&bytes), true))
    });
    // An explicit request: encapsulation header and CPF around a GetOD (32h).
    let get_od = vec![0x32, 0x03, 0x20, 0x64, 0x24, 0x01, 0x30, 0x64, 0x60, 0x00];
    let items = vec![cpf::Item::Null, cpf::Item::UnconnectedData(get_od)];
    let rr = encap::RrData::new(0, items.clone());
    let packet = encap::Packet::new(encap::Command(0x6F), 0x1111, [0; 8], rr.encode());
    g.bench_function("SendRRData encode (header + CPF)", |b| {
        b.iter(|| {
            let rr = encap::RrData::new(0, black_box(&items).clone());
            encap::Packet::new(encap::Command(0x6F), 0x1111, [0; 8], rr.encode()).encode()
        })
    });
    let wire = packet.encode();
    g.bench_function("SendRRData decode (header + CPF)", |b| {
        b.iter(|| {
            let p = encap::Packet::decode(black_box(&wire)).expect("a packet");
            encap::RrData::decode(&p.data).expect("CPF")
        })
    });
    g.finish();
}

fn pdi(c: &mut Criterion) {
    let mut g = c.benchmark_group("pdi");
    g.throughput(Throughput::Elements(1));
    let bytes = [0xD0, 0x07, 0, 0, 0xC8, 0, 0x00, 0x14];
    g.bench_function("RX image decode + encode", |b| {
        b.iter(|| {
            RxImage::from_bytes(black_box(&bytes))
                .expect("an image")
                .to_bytes()
        })
    });
    let tx = [0x08, 0x40, 0, 0, 0xD0, 0x07, 0, 0];
    g.bench_function("TX image decode + encode", |b| {
        b.iter(|| {
            TxImage::from_bytes(black_box(&tx))
                .expect("an image")
                .to_bytes()
        })
    });
    g.finish();
}

criterion_group!(benches, modbus, canopen, enip, pdi);
criterion_main!(benches);

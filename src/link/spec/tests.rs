use super::*;

fn ok(text: &str) -> LinkSpec {
    text.parse().unwrap_or_else(|e| panic!("{text}: {e}"))
}

fn err(text: &str) -> String {
    match text.parse::<LinkSpec>() {
        Ok(spec) => panic!("{text} parsed as {spec:?}"),
        Err(e) => e.reason,
    }
}

#[test]
fn every_form_of_the_issue_parses_with_its_defaults() {
    assert_eq!(ok("sim"), LinkSpec::Sim);
    assert_eq!(ok("sim://"), LinkSpec::Sim);
    assert_eq!(
        ok("modbus-tcp://192.168.2.10"),
        LinkSpec::ModbusTcp {
            host: "192.168.2.10".into(),
            port: 502,
            unit: 0,
            words: WordOrder::High
        }
    );
    assert_eq!(
        ok("modbus-tcp://localhost:1502?unit=3"),
        LinkSpec::ModbusTcp {
            host: "localhost".into(),
            port: 1502,
            unit: 3,
            words: WordOrder::High
        }
    );
    assert_eq!(
        ok("modbus-tcp://[::1]:1502"),
        LinkSpec::ModbusTcp {
            host: "::1".into(),
            port: 1502,
            unit: 0,
            words: WordOrder::High
        }
    );
    assert_eq!(
        ok("modbus-rtu:///dev/ttyUSB0"),
        LinkSpec::ModbusRtu {
            path: "/dev/ttyUSB0".into(),
            baud: 19_200,
            parity: Parity::Even,
            stop_bits: 1,
            slave: 5,
            words: WordOrder::High
        }
    );
    assert_eq!(
        ok("modbus-rtu://COM3?baud=115200&parity=none&stop=2&slave=7&words=low"),
        LinkSpec::ModbusRtu {
            path: "COM3".into(),
            baud: 115_200,
            parity: Parity::None,
            stop_bits: 2,
            slave: 7,
            words: WordOrder::Low
        }
    );
    assert_eq!(
        ok("canopen+socketcan://can0?node=1"),
        LinkSpec::CanopenSocketcan {
            iface: "can0".into(),
            can: CanopenOptions::default()
        }
    );
    assert_eq!(
        ok("canopen+slcan:///dev/ttyACM0?bitrate=500000&node=127"),
        LinkSpec::CanopenSlcan {
            path: "/dev/ttyACM0".into(),
            bitrate: 500_000,
            can: CanopenOptions {
                node: 127,
                ..CanopenOptions::default()
            }
        }
    );
    assert_eq!(
        ok("enip://10.0.0.5?io=common&rpi=20"),
        LinkSpec::Enip {
            host: "10.0.0.5".into(),
            port: 44818,
            enip: EnipOptions {
                io: EnipIo::Common,
                rpi_ms: 20,
                ..EnipOptions::default()
            }
        }
    );
}

#[test]
fn display_round_trips() {
    for text in [
        "sim",
        "modbus-tcp://127.0.0.1:1502?unit=0",
        "modbus-tcp://[::1]:502?unit=9",
        "modbus-tcp://10.0.0.1:502?unit=0&words=low",
        "modbus-rtu:///dev/ttyUSB0?baud=19200&parity=even&stop=1&slave=5",
        "canopen+socketcan://can0?node=1",
        "canopen+slcan://COM4?bitrate=1000000&node=1",
        "canopen+slcan:///dev/ttyACM0?bitrate=500000&node=3&pdo=4&keep_pdo=1",
        "canopen+sim://?node=1",
        "canopen+sim://?node=2&self_start=1",
        "modbus-rtu://COM3?baud=115200&parity=none&stop=2&slave=7&words=low",
        "enip://127.0.0.1:44818?io=pdi&rpi=10",
        "enip://127.0.0.1:44818?io=pdi&rpi=4&cmd_at=8&config=0&udp=0",
        "enip://[::1]:2000?io=explicit&rpi=10&udp=2222",
    ] {
        assert_eq!(ok(text).to_string(), text);
        assert_eq!(ok(&ok(text).to_string()), ok(text));
    }
    for scheme in [
        "canopen+sim",
        "sim",
        "modbus-tcp",
        "modbus-rtu",
        "canopen+socketcan",
        "canopen+slcan",
        "enip",
    ] {
        let spec = LinkSpec::default_for(scheme).unwrap();
        assert_eq!(spec.scheme(), scheme);
        assert_eq!(ok(&spec.to_string()), spec);
    }
}

#[test]
fn malformed_strings_say_what_is_wrong() {
    assert_eq!(err(""), "it is empty");
    assert!(err("modbus").contains("no scheme"));
    assert!(err("profibus://x").contains("unknown scheme 'profibus'"));
    assert!(err("modbus-tcp://").contains("host is missing"));
    assert!(err("modbus-tcp://h:99999").contains("port '99999'"));
    assert!(err("modbus-tcp://h?unit=300").contains("unit=300 is out of range 0 … 255"));
    assert!(
        err("modbus-tcp://h?unti=3")
            .contains("unknown parameter 'unti' (this bus takes unit, words)")
    );
    assert!(err("modbus-tcp://h?words=middle").contains("use high"));
    assert!(err("modbus-tcp://h?unit").contains("has no value"));
    assert!(err("modbus-tcp://h?unit=1&unit=2").contains("given twice"));
    assert!(err("modbus-tcp://::1:502").contains("brackets"));
    assert!(err("modbus-rtu://?baud=9600").contains("serial port path is missing"));
    assert!(err("modbus-rtu://COM1?parity=mark").contains("use none, even or odd"));
    assert!(err("modbus-rtu://COM1?slave=0").contains("slave=0 is out of range 1 … 247"));
    assert!(err("canopen+socketcan://can0?node=128").contains("node=128"));
    assert!(err("canopen+sim://?pdo=5").contains("pdo=5 is out of range 1 … 4"));
    assert!(err("canopen+slcan://COM1?bitrate=300000").contains("not a CAN bit rate"));
    assert!(err("enip://h?io=both").contains("use pdi, common or explicit"));
    assert!(err("enip://h?cmd_at=9").contains("cmd_at=9 is out of range 7 … 8"));
    assert!(err("enip://h?udp=x").contains("udp='x'"));
    assert!(err("sim://x").contains("no target"));
    let full = "x".parse::<LinkSpec>().unwrap_err().to_string();
    assert!(
        full.contains("Forms: sim | modbus-tcp://HOST:PORT?unit=0"),
        "{full}"
    );
}

#[test]
fn a_query_replaces_what_it_names_by_the_rules_of_a_whole_string() {
    let base = ok("enip://10.0.0.5?io=common&rpi=20");
    assert_eq!(
        base.with_query("&udp=0&cmd_at=8").map(|s| s.to_string()),
        Ok("enip://10.0.0.5:44818?io=common&rpi=20&cmd_at=8&udp=0".to_owned())
    );
    assert_eq!(base.with_query(""), Ok(base.clone()));
    assert_eq!(
        base.with_query("cmd_at=9"),
        Err("cmd_at=9 is out of range 7 … 8".to_owned())
    );
    assert_eq!(
        base.with_query("udp=1&udp=2"),
        Err("parameter 'udp' is given twice".to_owned())
    );
    assert!(
        base.with_query("node=2")
            .is_err_and(|e| e.contains("unknown parameter 'node'"))
    );
    assert!(
        LinkSpec::Sim
            .with_query("unit=1")
            .is_err_and(|e| e.contains("this bus takes no parameters"))
    );
}

#[test]
fn the_query_beyond_a_base_gives_the_spec_back() {
    for (text, base) in [
        (
            "enip://h:1?io=common&rpi=4&cmd_at=8&config=0&udp=0",
            "enip://h:1?io=common&rpi=4",
        ),
        (
            "canopen+slcan://COM5?bitrate=500000&node=9&keep_pdo=1",
            "canopen+slcan://COM5?bitrate=500000&node=9",
        ),
        (
            "modbus-tcp://h:502?unit=3&words=low",
            "modbus-tcp://h:502?unit=3",
        ),
        // The base may differ from the defaults too: then the query says so.
        (
            "enip://h:1?io=pdi&rpi=10",
            "enip://h:1?io=pdi&rpi=10&udp=2222",
        ),
    ] {
        let (spec, base) = (ok(text), ok(base));
        let beyond = spec.query_beyond(&base);
        assert_eq!(
            base.with_query(&beyond),
            Ok(spec.clone()),
            "{text}: {beyond}"
        );
    }
    let spec = ok("canopen+sim://?node=2&pdo=3&self_start=1");
    assert_eq!(
        spec.query_beyond(&ok("canopen+sim://?node=2")),
        "pdo=3&self_start=1"
    );
    assert_eq!(spec.query_beyond(&spec), "");
    assert_eq!(
        ok("enip://h?udp=2222").query_beyond(&ok("enip://h")),
        "udp=2222"
    );
    assert_eq!(
        ok("enip://h").query_beyond(&ok("enip://h?udp=2222")),
        "udp=auto"
    );
}

#[test]
fn a_spec_built_in_code_is_checked_by_reading_its_string_back() {
    assert_eq!(ok("canopen+sim://?node=5").check(), Ok(()));
    let zero = LinkSpec::CanopenSim {
        can: CanopenOptions {
            node: 0,
            ..CanopenOptions::default()
        },
    };
    assert_eq!(
        zero.check(),
        Err("node=0 is out of range 1 … 127".to_owned())
    );
    let path = LinkSpec::CanopenSlcan {
        path: "COM5?x=1".into(),
        bitrate: 1_000_000,
        can: CanopenOptions::default(),
    };
    assert!(path.check().is_err());
    let bitrate = LinkSpec::CanopenSlcan {
        path: "COM5".into(),
        bitrate: 300_000,
        can: CanopenOptions::default(),
    };
    assert!(
        bitrate
            .check()
            .is_err_and(|e| e.contains("not a CAN bit rate"))
    );
}

#[test]
fn hosts_and_numbers_are_read_alone_as_in_a_string() {
    assert_eq!(parse_host(" [fe80::1] "), Ok("fe80::1".to_owned()));
    assert_eq!(parse_host("::1"), Ok("::1".to_owned()));
    assert_eq!(parse_host("drive.local"), Ok("drive.local".to_owned()));
    assert_eq!(parse_host(""), Err("the host is missing".to_owned()));
    assert_eq!(parse_host("[]"), Err("the host is missing".to_owned()));
    assert_eq!(
        parse_host("a/b"),
        Err("'a/b' is not a host name".to_owned())
    );
    assert_eq!(number(" 0x10 ", &NODES), Ok(16u8));
    assert_eq!(number("1_000", &RPI_MS), Ok(1000u32));
    assert_eq!(number("128", &NODES), Err(BadNumber::OutOfRange(128)));
    assert_eq!(number("-1", &UNITS), Err(BadNumber::OutOfRange(-1)));
    assert_eq!(number("x", &UNITS), Err(BadNumber::NotANumber));
}

//! `axisctl decode` of what issue 15 found still shown raw: the Profibus
//! image's answer bytes and the PA-CONTROL CMD reply in both written forms.

mod common;

use common::run;

#[test]
fn profibus_image_answer_is_decoded_not_a_debug_string() {
    let r = run(&["--json", "decode", "profibus-image", "0a3c0000403f00000010270000040012"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["answer_decoded"], "ActPos = 0.75");
    assert_eq!(r.json()["answer_details"]["param"], "ActPos");
    let text = run(&["decode", "profibus-image", "0a 27 02 00 00 00 00 00 00 10 27 00 00 04 00 12"]);
    assert_eq!(text.code, 0, "{}", text.stderr);
    assert!(
        text.stdout.contains("answer      0a 27 02 00 00 00 00 00  CubeState = 2 [STATE_HOME_OK]"),
        "{}",
        text.stdout
    );
    assert!(!text.stdout.contains("Get {") && !text.stdout.contains("[0a,"), "{}", text.stdout);
    let bad = run(&["--json", "decode", "profibus-image", "ff3c0000403f00000010270000040012"]);
    assert_eq!(bad.code, 0);
    assert!(bad.json()["answer_decoded"].is_null());
    assert_eq!(bad.json()["answer_error"], "unknown command id 0xff");
}

#[test]
fn pac_cmd_reply_takes_8_hex_bytes_and_the_0x_number_alike() {
    let forms = ["00 00 00 01 00 01 A0 00", "00:00:00:01:00:01:a0:00", "000000010001A000", "0x000000010001A000"];
    let outs: Vec<_> = forms.iter().map(|f| run(&["--json", "decode", "pac-cmd-reply", f])).collect();
    for (f, r) in forms.iter().zip(&outs) {
        assert_eq!(r.code, 0, "{f}: {}", r.stderr);
        assert_eq!(r.json(), outs[0].json(), "{f}");
    }
    assert_eq!(run(&["decode", "pac-cmd-reply", "00 00 00 01 00 01 A0"]).code, 2, "7 bytes");
}

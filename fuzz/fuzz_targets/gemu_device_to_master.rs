//! Fuzzes the GEMÜ cPos device→master decoders: the 11-byte image, the 8-byte parameter
//! channel and its typed answer, and the client consuming arbitrary device images.
#![no_main]

use canola_frame::{Duration, Instant};
use canola_gemu::channel::{Answer, Channel};
use canola_gemu::client::{Client, ClientConfig};
use canola_gemu::image::DeviceImage;
use canola_gemu::{ActionRequest, action::RunFunction, params::ParamId};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Whole image: decode never panics; a decoded image re-encodes to the same bytes.
    if let Ok(img) = DeviceImage::parse(data) {
        assert_eq!(&img.to_bytes()[..], data);
    }
    // Channel and typed answer: lossless.
    if let Ok(ch) = Channel::parse(data.get(..8).unwrap_or(data)) {
        assert_eq!(Answer::from_channel(&ch).to_channel(ch.toggle), ch);
    }
    // The client fed with a stream of 11-byte images never panics.
    let mut client = Client::new(ClientConfig::default());
    let mut now = Instant::ZERO;
    let _ = client.get(now, ParamId::MODE);
    let _ = client.action(now, ActionRequest::InitValve(RunFunction::Start));
    let _ = client.read_error_list(now, 0);
    for chunk in data.chunks(11) {
        now += Duration::from_millis(10);
        let _ = client.handle_bytes(now, chunk);
        if chunk.len() < 11 {
            // Also try the channel on its own, with the toggle the client used.
            let mut bytes = [0u8; 11];
            bytes[3..].copy_from_slice(&client.image().channel.to_bytes());
            for (b, c) in bytes[3..].iter_mut().skip(1).zip(chunk) {
                *b = *c;
            }
            let _ = client.handle_bytes(now, &bytes);
        }
        if client.poll_timeout().is_some_and(|t| t <= now) {
            client.handle_timeout(now);
        }
        while client.poll_event().is_some() {}
        let _ = client.poll_transmit();
    }
});

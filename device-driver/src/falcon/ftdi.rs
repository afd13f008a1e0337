//! FTDI FT232 set-up for the Falcon: vendor control requests, baud divisors, and the firmware
//! loader's mode sequence (as published by libnifalcon; written here from the protocol notes).

/// Vendor request type: host-to-device, vendor, device (bmRequestType 0x40).
pub const REQUEST_TYPE_OUT: u8 = 0x40;
/// SIO_RESET (purge buffers).
pub const SIO_RESET: u8 = 0;
/// SIO_MODEM_CTRL (DTR / RTS).
pub const SIO_MODEM_CTRL: u8 = 1;
/// SIO_SET_FLOW_CTRL.
pub const SIO_SET_FLOW_CTRL: u8 = 2;
/// SIO_SET_BAUD_RATE.
pub const SIO_SET_BAUD_RATE: u8 = 3;
/// SIO_SET_DATA (bits, parity, stop bits).
pub const SIO_SET_DATA: u8 = 4;
/// SIO_SET_LATENCY_TIMER.
pub const SIO_SET_LATENCY_TIMER: u8 = 9;
/// SIO_RESET value: purge the receive buffer.
pub const PURGE_RX: u16 = 1;
/// SIO_RESET value: purge the transmit buffer.
pub const PURGE_TX: u16 = 2;
/// Modem control: DTR high (value 1, mask 1 << 8).
pub const DTR_HIGH: u16 = 0x0101;
/// Modem control: DTR low.
pub const DTR_LOW: u16 = 0x0100;
/// Modem control: RTS low (value 0, mask 2 << 8).
pub const RTS_LOW: u16 = 0x0200;
/// SIO_SET_DATA value for 8 data bits, no parity, 1 stop bit.
pub const DATA_8N1: u16 = 8;
/// Divisor value for 9600 baud (loader handshake).
pub const BAUD_9600: u16 = 0x4138;
/// Divisor value of the firmware upload: integer divisor 21, 142 857 baud (nominal 140 000).
pub const BAUD_LOADER: u16 = 0x0015;
/// Divisor value of normal running (nominal 1 456 312 baud; divisor 2 = 1.5 Mbaud).
pub const BAUD_NORMAL: u16 = 0x0002;
/// USB bulk OUT endpoint.
pub const EP_OUT: u8 = 0x02;
/// USB bulk IN endpoint.
pub const EP_IN: u8 = 0x81;
/// Bytes of modem status the FT232 puts before the data of every IN packet.
pub const STATUS_BYTES: usize = 2;
/// Largest IN packet (full-speed bulk).
pub const MAX_PACKET: usize = 64;

/// Baud-rate divisor of an FT232BM/R (3 MHz base, eighths of a step) as (wValue, wIndex).
/// `None` for 0 or rates too low to encode.
pub fn baud_divisor(baud: u32) -> Option<(u16, u16)> {
    if baud == 0 {
        return None;
    }
    // Divisor in eighths, rounded to nearest.
    let div8 = (24_000_000u64 + u64::from(baud) / 2) / u64::from(baud);
    if div8 <= 8 {
        return Some((0, 0)); // 3 Mbaud
    }
    if div8 < 16 {
        return Some((1, 0)); // 2 Mbaud (divisor 1.5)
    }
    let int = div8 / 8;
    if int >= 1 << 14 {
        return None;
    }
    // Fraction code order of the FT232BM: 0, 1/8, 1/4, 3/8, 1/2, 5/8, 3/4, 7/8.
    const FRAC: [u64; 8] = [0, 3, 2, 4, 1, 5, 6, 7];
    let code = FRAC.get((div8 % 8) as usize).copied().unwrap_or(0);
    let encoded = int | (code << 14);
    Some(((encoded & 0xFFFF) as u16, (encoded >> 16) as u16))
}

/// Baud rate an encoded (wValue, wIndex) divisor gives on an FT232BM/R.
pub fn baud_of_divisor(value: u16, index: u16) -> f64 {
    let encoded = u32::from(value) | (u32::from(index) << 16);
    let int = encoded & 0x3FFF;
    match (int, encoded >> 14) {
        (0, 0) => 3_000_000.0,
        (1, 0) => 2_000_000.0,
        _ => {
            const EIGHTHS: [u32; 8] = [0, 4, 2, 1, 3, 5, 6, 7];
            let frac = EIGHTHS
                .get((encoded >> 14) as usize & 7)
                .copied()
                .unwrap_or(0);
            3_000_000.0 * 8.0 / f64::from(int * 8 + frac)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn divisors_match_published_values() {
        assert_eq!(baud_divisor(9600), Some((BAUD_9600, 0)));
        assert_eq!(baud_divisor(1_456_312), Some((BAUD_NORMAL, 0)));
        assert_eq!(baud_divisor(3_000_000), Some((0, 0)));
        assert_eq!(baud_divisor(0), None);
        assert_eq!(baud_divisor(100), None);
        // The loader's integer divisor 21 is within 2.1 % of the nominal 140 000 baud.
        let b = baud_of_divisor(BAUD_LOADER, 0);
        assert!((b - 140_000.0).abs() / 140_000.0 < 0.021, "{b}");
        // Encoding and decoding agree for a spread of rates (within 1/16 of a step).
        for baud in [
            300u32, 1200, 19_200, 57_600, 115_200, 230_400, 460_800, 921_600,
        ] {
            let (v, i) = baud_divisor(baud).unwrap();
            let got = baud_of_divisor(v, i);
            assert!(
                (got - f64::from(baud)).abs() / f64::from(baud) < 0.01,
                "{baud} -> {got}"
            );
        }
    }
}

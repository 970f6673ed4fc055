//! What FC 7 (Read Exception Status), FC 17 (0x11, Report Server ID) and FC 43 / MEI 14
//! (Read Device Identification) report about the device, Application Protocol v1.1b3 §6.7,
//! §6.13, §6.21: kept beside a map's values, set by the application. Nothing without the
//! features that answer them (`diagnostics`, `device-id`).

use crate::slave::pdu::device_id::Identification;

/// FC 7's status bits, FC 17's description, FC 43's objects.
#[doc(hidden)]
#[derive(Clone, Debug, Default)]
pub struct Device {
    #[cfg(feature = "diagnostics")]
    exception_status: u8,
    #[cfg(feature = "diagnostics")]
    device_info: &'static [u8],
    #[cfg(feature = "device-id")]
    identification: Option<&'static Identification>,
}

impl Device {
    /// Nothing set.
    pub const fn new() -> Self {
        Device {
            #[cfg(feature = "diagnostics")]
            exception_status: 0,
            #[cfg(feature = "diagnostics")]
            device_info: &[],
            #[cfg(feature = "device-id")]
            identification: None,
        }
    }

    /// FC 7's status bits (0 without feature `diagnostics`).
    #[inline(always)]
    pub fn exception_status(&self) -> u8 {
        #[cfg(feature = "diagnostics")]
        return self.exception_status;
        #[cfg(not(feature = "diagnostics"))]
        0
    }

    /// FC 17's device description (empty without feature `diagnostics`).
    #[inline(always)]
    pub fn device_info(&self) -> &[u8] {
        #[cfg(feature = "diagnostics")]
        return self.device_info;
        #[cfg(not(feature = "diagnostics"))]
        &[]
    }

    /// Sets FC 7's status bits (feature `diagnostics`).
    #[cfg(feature = "diagnostics")]
    pub fn set_exception_status(&mut self, bits: u8) {
        self.exception_status = bits;
    }

    /// Sets FC 17's device description (feature `diagnostics`).
    #[cfg(feature = "diagnostics")]
    pub fn set_device_info(&mut self, info: &'static [u8]) {
        self.device_info = info;
    }

    /// FC 43's objects (none without feature `device-id`).
    #[inline(always)]
    pub fn identification(&self) -> Option<&'static Identification> {
        #[cfg(feature = "device-id")]
        return self.identification;
        #[cfg(not(feature = "device-id"))]
        None
    }

    /// Sets FC 43's objects (feature `device-id`).
    #[cfg(feature = "device-id")]
    pub fn set_identification(&mut self, identification: &'static Identification) {
        self.identification = Some(identification);
    }
}

//! The application's reads and writes of a role's values, the same for the RTU slave and
//! the TCP server: `get`, `set`, `get_wide`, `set_wide`, `master_writes`, each holding
//! interrupts off as briefly as the model allows. Each role's methods of those names call
//! these.

use crate::avr::reg;
use crate::error::Error;
use crate::protocol::reference::IntoReference;
use crate::slave::model::DataModel;
use crate::slave::words::Place;

/// A role that serves a data model to masters: the application reaches the model through
/// [`Values::with_model`], with interrupts disabled.
pub(crate) trait Values {
    /// The data model.
    type Model: DataModel;

    /// Runs `f` on the model with interrupts disabled: `None` before the role's start or
    /// inside another access.
    fn with_model<R>(&self, f: impl FnOnce(&mut Self::Model) -> R) -> Option<R>;

    // `get`, `set`, `get_wide` and `set_wide` work out where the value is (the map's lookup,
    // the word's byte order, a bit's mask) and what to store before interrupts go off, and
    // hold them off only for the loads or stores (`DataModel::place`); a model without a
    // layout fixed at build time (`Bank`, a `DataModel` of your own) is asked with
    // interrupts off, as `with` would.

    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let reference = reference.into_reference()?;
        match Self::Model::place(reference) {
            Place::Ask => self.with_model(|model| model.value(reference)).unwrap_or(Err(Error::NotFound)),
            Place::Missing => Err(Error::NotFound),
            place => {
                let place = computed(place);
                self.with_model(|model| model.load(place)).map(|loaded| place.value(loaded)).ok_or(Error::NotFound)
            }
        }
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let reference = reference.into_reference()?;
        match Self::Model::place(reference) {
            Place::Ask => {
                // Worked out before interrupts go off, whatever it took (`reg::computed`).
                let value = reg::computed(value);
                self.with_model(|model| model.set_value(reference, value)).unwrap_or(Err(Error::NotFound))
            }
            Place::Missing => Err(Error::NotFound),
            place => {
                let place = computed(place);
                // What is stored, and `value` with whatever it took, worked out before
                // interrupts go off.
                let stored = reg::computed(place.stored(value));
                self.with_model(|model| model.store(place, stored)).ok_or(Error::NotFound)
            }
        }
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]): both read with interrupts disabled, so never a pair the master
    /// is writing half of (its write runs whole in an interrupt).
    fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        let first = first.into_reference()?;
        let (first_ref, second_ref) = crate::slave::model::pair(first)?;
        match (Self::Model::place(first_ref), Self::Model::place(second_ref)) {
            (Place::Ask, _) | (_, Place::Ask) => {
                self.with_model(|model| model.get_wide(first, order)).unwrap_or(Err(Error::NotFound))
            }
            (Place::Missing, _) | (_, Place::Missing) => Err(Error::NotFound),
            (a, b) => {
                // Both loads in one critical section.
                let (x, y) = self.with_model(|model| (model.load(a), model.load(b))).ok_or(Error::NotFound)?;
                Ok(order.join([a.value(x), b.value(y)]))
            }
        }
    }

    /// Sets the two registers from `first` to `value` in `order`, both with interrupts
    /// disabled: a master never reads the pair half old, half new.
    fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        let first = first.into_reference()?;
        let (first_ref, second_ref) = crate::slave::model::pair(first)?;
        let [a, b] = order.split(value);
        match (Self::Model::place(first_ref), Self::Model::place(second_ref)) {
            (Place::Ask, _) | (_, Place::Ask) => {
                let bits = crate::WordOrder::HighFirst.join::<u32>([reg::computed(a), reg::computed(b)]);
                self.with_model(|model| model.set_wide(first, bits, crate::WordOrder::HighFirst))
                    .unwrap_or(Err(Error::NotFound))
            }
            (Place::Missing, _) | (_, Place::Missing) => Err(Error::NotFound),
            (pa, pb) => {
                let (sa, sb) = (reg::computed(pa.stored(a)), reg::computed(pb.stored(b)));
                // Both stores in one critical section: the slave's interrupts, which answer
                // the master, see the old pair or the new one, never half of each.
                self.with_model(|model| {
                    model.store(pa, sa);
                    model.store(pb, sb);
                })
                .ok_or(Error::NotFound)
            }
        }
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]): compare it with the last value seen to learn that
    /// the master wrote something.
    fn master_writes(&self) -> u16 {
        self.with_model(|model| model.master_writes()).unwrap_or(0)
    }
}

/// `place`, worked out before this point. A bit's mask, `1 << (i % 8)`, is a loop on the
/// AVR that the compiler could sink into the critical section that alone uses it: the mask
/// passes [`reg::computed`]. A word's index does not: the map's lookup ends in a choice
/// between its ranges, which the compiler has not sunk into the section (`bench calls`
/// shows it if it does), and a barrier would cost every call with a known reference its
/// folded address.
#[inline(always)]
fn computed(place: Place) -> Place {
    match place {
        Place::Bit(i, mask) => Place::Bit(i, reg::computed(u16::from(mask)) as u8),
        other => other,
    }
}

#pragma once
// The whole wire contract in one include (pure data and codecs, no I/O). Prefer the
// individual headers where only one idea is needed.
#include "firmware_if/bus_layout.hpp"
#include "firmware_if/byte_order.hpp"
#include "firmware_if/can_frame.hpp"
#include "firmware_if/can_frame_bits.hpp"
#include "firmware_if/cia402.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/emcy.hpp"
#include "firmware_if/heartbeat.hpp"
#include "firmware_if/nmt.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/result.hpp"
#include "firmware_if/sdo.hpp"
#include "firmware_if/sync.hpp"
#include "firmware_if/units.hpp"

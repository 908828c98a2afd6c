#pragma once
// What a plugin's source includes to describe its kinds and export its descriptor.
//
//   class Align : public projtour::Behaviour {
//    public:
//     Align(const projtour::Params& params, const projtour::RunContext& run);
//     ...
//   };
//   const projtour_param_desc kAlignParams[] = {
//       {"method", "string", "projective_icp", "registration method"}, ...};
//   const char* const kAlignOutcomes[] = {"succeeded", "poor_fit", "no_target"};
//   const projtour_kind_desc kKinds[] = {
//       projtour::behaviour_kind<Align>("align", "ICP of the model against the frame",
//                                       kAlignParams, kAlignOutcomes)};
//   PROJTOUR_PLUGIN("align", "1.0.0", kKinds)
#include <cstring>
#include <exception>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/params.hpp"
#include "projtour/contract/plugin_abi.h"

namespace projtour::plugin_detail {

inline void copy_message(const char* message, char* error, size_t error_size) {
  if (error == nullptr || error_size == 0) return;
  std::strncpy(error, message, error_size - 1);
  error[error_size - 1] = '\0';
}

// Exceptions never cross the C boundary: they become the error message.
template <typename Base, typename T>
void* create(const void* params, const void* run, char* error, size_t error_size) noexcept {
  try {
    Base* object = new T(*static_cast<const Params*>(params), *static_cast<const RunContext*>(run));
    return object;
  } catch (const std::exception& e) {
    copy_message(e.what(), error, error_size);
  } catch (...) {
    copy_message("unknown exception", error, error_size);
  }
  return nullptr;
}

template <typename Base>
void destroy(void* object) noexcept {
  delete static_cast<Base*>(object);
}

template <auto check>
int validate(const void* params, char* error, size_t error_size) noexcept {
  try {
    check(*static_cast<const Params*>(params));
    return 0;
  } catch (const std::exception& e) {
    copy_message(e.what(), error, error_size);
  }
  return 1;
}

}  // namespace projtour::plugin_detail

namespace projtour {

// A kind's load-time validate() from a function that throws on bad values (typically the same
// settings reader its constructor uses, so load and create check alike).
template <auto check>
constexpr projtour_validate_fn validator() {
  return &plugin_detail::validate<check>;
}

template <typename T, size_t NP, size_t NO>
constexpr projtour_kind_desc behaviour_kind(const char* name, const char* description,
                                            const projtour_param_desc (&params)[NP],
                                            const char* const (&outcomes)[NO],
                                            projtour_validate_fn validate = nullptr) {
  return {name,
          PROJTOUR_FAMILY_BEHAVIOUR,
          nullptr,
          description,
          params,
          static_cast<uint32_t>(NP),
          outcomes,
          static_cast<uint32_t>(NO),
          &plugin_detail::create<Behaviour, T>,
          &plugin_detail::destroy<Behaviour>,
          validate,
          nullptr,
          0};
}

template <typename T, size_t NO>
constexpr projtour_kind_desc behaviour_kind(const char* name, const char* description,
                                            const char* const (&outcomes)[NO]) {
  return {name,
          PROJTOUR_FAMILY_BEHAVIOUR,
          nullptr,
          description,
          nullptr,
          0,
          outcomes,
          static_cast<uint32_t>(NO),
          &plugin_detail::create<Behaviour, T>,
          &plugin_detail::destroy<Behaviour>,
          nullptr,
          nullptr,
          0};
}

// `interface`: "base" | "laser" | "pan_tilt" | "depth_camera" | "projector" |
// "colour_camera".
template <typename T, size_t NP>
constexpr projtour_kind_desc driver_kind(const char* name, const char* interface,
                                         const char* description,
                                         const projtour_param_desc (&params)[NP],
                                         projtour_validate_fn validate = nullptr) {
  return {name,
          PROJTOUR_FAMILY_DRIVER,
          interface,
          description,
          params,
          static_cast<uint32_t>(NP),
          nullptr,
          0,
          &plugin_detail::create<Driver, T>,
          &plugin_detail::destroy<Driver>,
          validate,
          nullptr,
          0};
}

template <typename T, size_t NP>
constexpr projtour_kind_desc service_kind(const char* name, const char* role,
                                          const char* description,
                                          const projtour_param_desc (&params)[NP],
                                          projtour_validate_fn validate = nullptr) {
  return {name,
          PROJTOUR_FAMILY_SERVICE,
          role,
          description,
          params,
          static_cast<uint32_t>(NP),
          nullptr,
          0,
          &plugin_detail::create<Service, T>,
          &plugin_detail::destroy<Service>,
          validate,
          nullptr,
          0};
}

// The blackboard keys a kind uses, for its descriptor:
//   const projtour_key_desc kAlignKeys[] = {projtour::reads(keys::kCapture),
//                                           projtour::writes(keys::kAlign)};
//   projtour::with_keys(projtour::behaviour_kind<Align>(...), kAlignKeys)
template <typename T>
constexpr projtour_key_desc reads(const Key<T>& key) {
  return {key.name, key.type, PROJTOUR_KEY_READ};
}
template <typename T>
constexpr projtour_key_desc reads_if_present(const Key<T>& key) {
  return {key.name, key.type, PROJTOUR_KEY_READ_OPTIONAL};
}
template <typename T>
constexpr projtour_key_desc writes(const Key<T>& key) {
  return {key.name, key.type, PROJTOUR_KEY_WRITE};
}
template <size_t NK>
constexpr projtour_kind_desc with_keys(projtour_kind_desc kind,
                                       const projtour_key_desc (&keys)[NK]) {
  kind.keys = keys;
  kind.key_count = static_cast<uint32_t>(NK);
  return kind;
}

}  // namespace projtour

#define PROJTOUR_PLUGIN(plugin_name, plugin_version, kinds_array)               \
  extern "C" __attribute__((visibility("default"))) const projtour_plugin_desc* \
  projtour_plugin_descriptor(void) {                                            \
    static const projtour_plugin_desc descriptor = {                            \
        PROJTOUR_ABI_VERSION, plugin_name, plugin_version, kinds_array,         \
        static_cast<uint32_t>(sizeof(kinds_array) / sizeof(kinds_array[0]))};   \
    return &descriptor;                                                         \
  }

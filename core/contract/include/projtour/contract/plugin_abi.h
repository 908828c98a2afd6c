/* The plugin ABI: plain C, so the loader can check a shared object before trusting it.
 * Each plugin shared object exports exactly one entry point, PROJTOUR_ENTRY_POINT, returning a
 * descriptor that lives as long as the library. The objects that create() returns are C++
 * objects of core's interfaces (projtour::Behaviour, projtour::Driver subclasses,
 * projtour::Service), so a plugin must be built against the same projtour core. */
#ifndef PROJTOUR_PLUGIN_ABI_H
#define PROJTOUR_PLUGIN_ABI_H

#include <stddef.h>
#include <stdint.h>

#include "projtour/contract/contract_version.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The ABI version is the contract library's SOVERSION: one number, bumped in one place
 * (core/contract/CMakeLists.txt), so a plugin descriptor and the library it links cannot
 * disagree about it. */
#define PROJTOUR_ABI_VERSION PROJTOUR_CONTRACT_SOVERSION
#define PROJTOUR_ENTRY_POINT "projtour_plugin_descriptor"

typedef enum projtour_family {
  PROJTOUR_FAMILY_BEHAVIOUR = 1,
  PROJTOUR_FAMILY_DRIVER = 2,
  PROJTOUR_FAMILY_SERVICE = 3
} projtour_family;

typedef struct projtour_param_desc {
  const char* name;
  const char* type;          /* "number" | "integer" | "boolean" | "string" */
  const char* default_value; /* YAML text; "" = required (strings: "" is the default) */
  const char* description;
} projtour_param_desc;

/* What a kind does with a blackboard key (projtour::Key<T>: name and type). The host checks,
 * when it loads a machine, that every PROJTOUR_KEY_READ has a writer upstream on every path. */
typedef enum projtour_key_access {
  PROJTOUR_KEY_READ = 1,          /* needs the value: a writer must come first */
  PROJTOUR_KEY_READ_OPTIONAL = 2, /* uses the value when there is one */
  PROJTOUR_KEY_WRITE = 3
} projtour_key_access;

typedef struct projtour_key_desc {
  const char* name; /* "align", "localization.estimate" */
  const char* type; /* "AlignResult": readers and writers of one name must agree */
  int32_t access;   /* projtour_key_access */
} projtour_key_desc;

/* create(): params is a `const projtour::Params*` already checked against the schema; run is a
 * `const projtour::RunContext*`. Returns the new object (projtour::Behaviour*,
 * projtour::Driver*, projtour::Service* by family) or NULL with a message in error. */
typedef void* (*projtour_create_fn)(const void* params, const void* run, char* error,
                                    size_t error_size);
typedef void (*projtour_destroy_fn)(void* object);
/* Optional load-time check of parameter values beyond their types: 0 = fine. */
typedef int (*projtour_validate_fn)(const void* params, char* error, size_t error_size);

typedef struct projtour_kind_desc {
  const char* name;      /* unique over all plugins: "align", "sim_base" */
  int32_t family;        /* projtour_family */
  const char* interface; /* drivers: "base" | "laser" | "pan_tilt" | "depth_camera" |
                            "projector" | "colour_camera"; services: their role ("localization");
                            else NULL */
  const char* description;
  const projtour_param_desc* params;
  uint32_t param_count;
  const char* const* outcomes; /* behaviours: the outcomes tick may return besides "failed" and
                                  "cancelled" */
  uint32_t outcome_count;
  projtour_create_fn create;
  projtour_destroy_fn destroy;
  projtour_validate_fn validate; /* may be NULL */
  const projtour_key_desc* keys; /* the blackboard keys it reads and writes; may be NULL */
  uint32_t key_count;
} projtour_kind_desc;

typedef struct projtour_plugin_desc {
  uint32_t abi_version; /* PROJTOUR_ABI_VERSION; checked before anything else is read */
  const char* name;
  const char* version;
  const projtour_kind_desc* kinds;
  uint32_t kind_count;
} projtour_plugin_desc;

typedef const projtour_plugin_desc* (*projtour_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* PROJTOUR_PLUGIN_ABI_H */

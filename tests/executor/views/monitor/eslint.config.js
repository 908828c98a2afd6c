// eslint over the live monitor's script (executor/views/assets/monitor/monitor.js), which runs in the
// operator's browser: the recommended rules, the browser's globals. ctest runs it
// (test_monitor_eslint, CMakeLists.txt); by hand: npx --prefix tests/executor/views/monitor eslint ...
import js from "@eslint/js";
import globals from "globals";

export default [
  js.configs.recommended,
  {
    files: ["**/*.js"],
    languageOptions: {
      ecmaVersion: 2022,
      sourceType: "script",
      globals: { ...globals.browser },
    },
  },
];

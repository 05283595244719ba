/* Preloaded (LD_PRELOAD) in the sanitizer test run only: dlclose() leaves libraries mapped, so that LeakSanitizer
 * can still name the library a leak at exit comes from. tools/lsan.supp suppresses by library name, and a library
 * the Vulkan loader has already unloaded shows as "<unknown module>". */
int dlclose(void* handle) {
  (void)handle;
  return 0;
}

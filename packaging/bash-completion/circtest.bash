# bash completion for circgen, circana and circlog-record (installed once per command name).
# The option names come from the program's own --help, so they cannot drift from it.

# Long options a command's --help lists (boost::program_options layout).
_circtest_options() {
  "$@" --help 2>/dev/null | sed -n 's/^  \(-[a-z] \[ \)\{0,1\}\(--[a-z][a-z0-9-]*\).*/\2/p'
}

_circtest() {
  local cur prev words cword
  _init_completion || return
  local cmd=("${words[0]}")
  if [[ ${words[0]} == circana ]]; then
    if ((cword == 1)); then
      local commands
      commands=$("${words[0]}" --help 2>/dev/null | sed -n 's/^.*circana \([a-z][a-z-]*\).*/\1/p' | sort -u)
      COMPREPLY=($(compgen -W "$commands --help --version" -- "$cur"))
      return
    fi
    cmd+=("${words[1]}")
  fi
  case $prev in
    --plane) COMPREPLY=($(compgen -W "XY YZ ZX" -- "$cur")); return ;;
    --dir) COMPREPLY=($(compgen -W "both ccw cw" -- "$cur")); return ;;
    --instrument) COMPREPLY=($(compgen -W "encoder grid ballbar" -- "$cur")); return ;;
    --g-method) COMPREPLY=($(compgen -W "min-zone least-squares" -- "$cur")); return ;;
    --f-centre) COMPREPLY=($(compgen -W "auto nominal lsc" -- "$cur")); return ;;
    --ini) _filedir ini; return ;;
    --program) _filedir ngc; return ;;
    -o | --output | --svg | --trace | --points | --before | --diagnosis | --compare | --limits-file | --changes) _filedir; return ;;
  esac
  if [[ $cur == -* ]]; then
    COMPREPLY=($(compgen -W "$(_circtest_options "${cmd[@]}")" -- "$cur"))
    return
  fi
  _filedir
}
complete -F _circtest circgen circana circlog-record

vim.lsp.enable({'rust-analyzer'})
